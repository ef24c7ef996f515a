"""Small worlds built in code, and where the course's reference maps are."""

from __future__ import annotations

from pathlib import Path

import numpy as np

REFERENCE_MAPS = Path(__file__).resolve().parent / "data"  # copies of the course reference maps

# The documented fields of `pico-gym bench` / `compare` JSON: one record per episode, a summary.
EPISODE_FIELDS = {
    "seed",
    "map",
    "success",
    "termination_reason",
    "time_s",
    "bumps",
    "path_length",
    "shortest_path_length",
    "min_clearance",
}
SUMMARY_FIELDS = {
    "success_rate",
    "bump_rate",
    "idle",
    "timeout",
    "time_median_s",
    "time_p90_s",
    "spl",
    "sct_median",
}


def box_room(half: float = 2.0) -> dict:
    """A closed square room of side 2*half centred on the origin (pico-gym JSON)."""
    h = half
    return {
        "points": [[-h, -h], [h, -h], [h, h], [-h, h]],
        "walls": [[0, 1], [1, 2], [2, 3], [3, 0]],
    }


def square_segments(half: float = 2.0) -> np.ndarray:
    h = half
    return np.array([[-h, -h, h, -h], [h, -h, h, h], [h, h, -h, h], [-h, h, -h, -h]], dtype=float)


def person_paused_behind(agent, metres: float = 0.5) -> np.ndarray:  # type: ignore[no-untyped-def]
    """Make a hospital agent's people tracker hold a person it saw walking a second ago, paused
    `metres` straight behind its pose estimate (out of the LRF's view, in no scan); returns where
    (map frame). In the robot's frame the person is at (-metres, 0)."""
    from pico_gym.agents.classic.tracking import Track

    p = agent.pose
    behind = np.array([p.x - metres * np.cos(p.theta), p.y - metres * np.sin(p.theta)])
    now = agent.steps * agent.spec.dt_s
    agent.world.tracker.tracks = [Track(7, behind, np.zeros(2), 0.3, now - 1.0, moving=True)]
    return behind
