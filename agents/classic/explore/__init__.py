"""The classic explore agent (2018: explore an unknown hospital, park backwards, find the object),
by seam:

    config     its settings
    occupancy  its map: a log-odds occupancy grid in its odometry frame (`OccupancyMap`)
    pose       odometry, optionally corrected against its map (`OdometryPose`)
    regions    grid geometry: distances, connected parts, rooms and the doors between them
    frontiers  the planner: frontiers and paths on its map (`FrontierPlanner`)
    motion     following a path, and the safety filters (`Follower`)
    parking    the parking wall and where on it to park
    search     the object, and the rooms to look into (`ObjectFinder`)
    states     the state machine, a function per state
    agent      `ExploreAgent`, which chains them each step
"""

from pico_gym.agents.classic.explore.agent import ExploreAgent, build
from pico_gym.agents.classic.explore.config import ExploreAgentConfig
from pico_gym.agents.classic.explore.states import State

__all__ = ["ExploreAgent", "ExploreAgentConfig", "State", "build"]
