"""Drawing an env's state with pygame: headless RGB arrays and a live window.

Shows the map (walls, low obstacles, doors open or closed, static obstacles, cabinets with their
fronts), the finish line, the episode's boxes and movers (with their pause circles), a task's
marks (the cabinets' arrival squares, order numbers and done flags), the robot's footprint and
heading, the LRF hit points, the trajectory, bump markers, the time, and an agent's `Overlay`
(placed through the odometry frame, so the agent's drift shows). The renderer reads only a
`SceneSnapshot` value (`PicoEnv.snapshot()`), never the env.
"""

from __future__ import annotations

import os
from typing import TYPE_CHECKING, Any

import numpy as np

from pico_gym.overlay import Overlay
from pico_gym.types import FloatArray, Pose
from pico_gym.world.geometry import transform_points
from pico_gym.world.movers import box_corners

if TYPE_CHECKING:
    from pico_gym.world.map import Map
    from pico_gym.world.scene import SceneSnapshot

os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")

CANVAS_PX = 640
MARGIN_PX = 24
WHITE = (255, 255, 255)
WALL = (20, 20, 20)
LOW = (150, 150, 150)
DOOR = (170, 110, 40)
OBSTACLE = (90, 90, 90)
FINISH = (0, 160, 60)
ROBOT = (240, 140, 0)
HEADING = (120, 60, 0)
SCAN = (220, 30, 30)
TRAIL = (40, 90, 220)
BUMP = (200, 0, 0)
OVERLAY = (160, 0, 200)
TEXT = (0, 0, 0)
CABINET = (70, 70, 160)
FRONT = (0, 90, 255)
SQUARE = (0, 150, 255)
DONE = (0, 170, 70)
OPEN_DOOR = (220, 190, 140)
BOX = (110, 80, 50)
MOVER = (200, 40, 120)
PAUSE = (240, 170, 210)


def _pygame() -> Any:
    try:
        import pygame
    except ImportError as error:  # pragma: no cover - depends on the install
        raise ImportError("rendering needs pygame: pip install 'pico-gym[render]'") from error
    return pygame


class View:
    """The map-to-pixel transform fitting a map's bounds into a square canvas (y up on screen)."""

    def __init__(self, bounds: tuple[float, float, float, float], size_px: int = CANVAS_PX) -> None:
        xmin, ymin, xmax, ymax = bounds
        span = max(xmax - xmin, ymax - ymin, 1e-6)
        self.scale = (size_px - 2 * MARGIN_PX) / span
        self.cx, self.cy = 0.5 * (xmin + xmax), 0.5 * (ymin + ymax)
        self.size = size_px

    def px(self, points: FloatArray) -> list[tuple[int, int]]:
        """Pixel coordinates of (N, 2) map points."""
        p = np.asarray(points, dtype=float).reshape(-1, 2)
        u = self.size / 2 + (p[:, 0] - self.cx) * self.scale
        v = self.size / 2 - (p[:, 1] - self.cy) * self.scale
        return [(int(round(a)), int(round(b))) for a, b in zip(u, v, strict=True)]


def draw_map(surface: Any, world: Map, view: View, closed_doors: tuple[int, ...] | None = None) -> None:
    """Draw a map's static content on a pygame surface (doors: closed ones solid, None = all)."""
    pygame = _pygame()
    for segments, colour, width in ((world.low_segments, LOW, 1), (world.wall_segments, WALL, 2)):
        for x1, y1, x2, y2 in segments:
            a, b = view.px(np.array([[x1, y1], [x2, y2]]))
            pygame.draw.line(surface, colour, a, b, width)
    for i, door in enumerate(world.door_segments):
        colour = DOOR if closed_doors is None or i in closed_doors else OPEN_DOOR
        for x1, y1, x2, y2 in door:
            a, b = view.px(np.array([[x1, y1], [x2, y2]]))
            pygame.draw.line(surface, colour, a, b, 2 if colour is DOOR else 1)
    for cabinet in world.cabinets:
        pygame.draw.polygon(surface, CABINET, view.px(world.polygon(cabinet)))
        i, j = cabinet[0]
        pygame.draw.line(surface, FRONT, *view.px(world.points[[i, j]]), 3)
    for polygon in world.obstacles:
        pygame.draw.polygon(surface, OBSTACLE, view.px(polygon))
    if world.finish is not None:
        a, b = view.px(world.finish)
        pygame.draw.line(surface, FINISH, a, b, 3)
    if world.start_pose is not None:
        pygame.draw.circle(surface, ROBOT, view.px(np.array(world.start_pose[:2]))[0], 4, 1)


def render_map_png(world: Map, path: str | os.PathLike[str], size_px: int = CANVAS_PX) -> None:
    """Draw a map alone into a PNG file."""
    pygame = _pygame()
    surface = pygame.Surface((size_px, size_px))
    surface.fill(WHITE)
    view = View(world.bounds, size_px)
    draw_map(surface, world, view)
    _scale_bar(surface, view)
    pygame.image.save(surface, os.fspath(path))


def save_gif(frames: list[np.ndarray], path: str | os.PathLike[str], fps: float, scale: float = 0.5) -> None:
    """Write RGB frames as an animated GIF (downscaled by `scale` to keep it small). A frame lasts
    at least 20 ms (browsers show shorter ones for 100 ms)."""
    from PIL import Image

    images = [Image.fromarray(f).resize((int(f.shape[1] * scale), int(f.shape[0] * scale))) for f in frames]
    images[0].save(path, save_all=True, append_images=images[1:], duration=max(20, int(1000 / fps)), loop=0)


def _draw_robots(surface: Any, view: View, state: SceneSnapshot) -> None:
    """The robot (filled, with its heading) and any other robot in the world (in outline)."""
    pygame = _pygame()
    for other in state.others:
        pygame.draw.polygon(surface, ROBOT, view.px(transform_points(other, state.outline)), 2)
    pose = state.pose
    pygame.draw.polygon(surface, ROBOT, view.px(transform_points(pose, state.outline)))
    a, b = view.px(transform_points(pose, np.array([[0.0, 0.0], [0.25, 0.0]])))
    pygame.draw.line(surface, HEADING, a, b, 2)


def _scale_bar(surface: Any, view: View) -> None:
    pygame = _pygame()
    pygame.font.init()
    length_px = int(view.scale)
    y = view.size - 10
    pygame.draw.line(surface, TEXT, (10, y), (10 + length_px, y), 2)
    font = pygame.font.Font(None, 18)
    surface.blit(font.render("1 m", True, TEXT), (14 + length_px, y - 7))


class Renderer:
    """Draws an env's state every call; `human` also shows it in a window at `fps`."""

    def __init__(self, mode: str, fps: int) -> None:
        pygame = _pygame()
        pygame.font.init()
        self.mode = mode
        self.fps = fps
        self.font = pygame.font.Font(None, 20)
        self.surface = pygame.Surface((CANVAS_PX, CANVAS_PX))
        self.window = None
        self.clock = None
        self._background: Any = None
        self._map: Map | None = None
        self._closed: tuple[int, ...] | None = None

    def _prepare(self, world: Map, closed_doors: tuple[int, ...]) -> View:
        if self._map is not world or self._closed != closed_doors:
            pygame = _pygame()
            self._map, self._closed = world, closed_doors
            self.view = View(world.bounds)
            self._background = pygame.Surface((CANVAS_PX, CANVAS_PX))
            self._background.fill(WHITE)
            draw_map(self._background, world, self.view, closed_doors)
            _scale_bar(self._background, self.view)
        return self.view

    def draw(self, state: SceneSnapshot, overlay: Overlay | None) -> np.ndarray | None:
        """Draw a state snapshot (and an agent overlay); returns RGB for rgb_array mode."""
        pygame = _pygame()
        view = self._prepare(state.map, state.closed_doors)
        surface = self.surface
        surface.blit(self._background, (0, 0))
        self._draw_marks(surface, view, state.marks)
        for polygon in state.boxes:
            pygame.draw.polygon(surface, BOX, view.px(polygon))
        movers = zip(state.movers, state.mover_sizes, state.mover_pause_m, strict=True)
        for (x, y, yaw), (length, width), pause in movers:
            centre = view.px(np.array([x, y]))[0]
            pygame.draw.circle(surface, PAUSE, centre, max(1, int(pause * view.scale)), 1)
            pygame.draw.polygon(surface, MOVER, view.px(box_corners(x, y, yaw, length, width)))
        if len(state.trajectory) > 1:
            pygame.draw.lines(surface, TRAIL, False, view.px(state.trajectory), 1)
        for p in state.bump_points:
            u, v = view.px(p)[0]
            pygame.draw.line(surface, BUMP, (u - 5, v - 5), (u + 5, v + 5), 2)
            pygame.draw.line(surface, BUMP, (u - 5, v + 5), (u + 5, v - 5), 2)
        for u, v in view.px(state.scan_points):
            if 0 <= u < CANVAS_PX and 0 <= v < CANVAS_PX:
                surface.set_at((u, v), SCAN)
        _draw_robots(surface, view, state)
        if overlay is not None:
            self._draw_overlay(surface, view, state, overlay)
        status = f"t = {state.sim_time_s:5.1f} s   bumps = {state.bumps}"
        if state.marks.get("status"):
            status += f"   {state.marks['status']}"
        if overlay is not None and overlay.text:
            status += f"   {overlay.text}"
        surface.blit(self.font.render(status, True, TEXT), (8, 6))

        if self.mode == "human":
            if self.window is None:
                pygame.display.init()
                self.window = pygame.display.set_mode((CANVAS_PX, CANVAS_PX))
                pygame.display.set_caption("pico-gym")
                self.clock = pygame.time.Clock()
            assert self.window is not None and self.clock is not None
            self.window.blit(surface, (0, 0))
            pygame.event.pump()
            pygame.display.flip()
            self.clock.tick(self.fps)
            return None
        return np.transpose(pygame.surfarray.array3d(surface), (1, 0, 2)).copy()

    def _draw_marks(self, surface: Any, view: View, marks: dict[str, Any]) -> None:
        """A task's marks: arrival squares (done ones green) with their place in the order, and
        lines (e.g. the explore task's parking wall)."""
        pygame = _pygame()
        for line, _label in marks.get("lines", ()):
            a, b = view.px(np.asarray(line, dtype=float).reshape(2, 2))
            pygame.draw.line(surface, DONE, a, b, 4)
        for square, label, done in marks.get("squares", ()):
            pygame.draw.polygon(surface, DONE if done else SQUARE, view.px(square), 2 if not done else 0)
            if label:
                centre = view.px(np.mean(square, axis=0))[0]
                text = self.font.render(label, True, TEXT)
                surface.blit(text, (centre[0] - text.get_width() // 2, centre[1] - text.get_height() // 2))

    def _draw_overlay(self, surface: Any, view: View, state: SceneSnapshot, overlay: Overlay) -> None:
        pygame = _pygame()
        if overlay.frame == "odom":
            frame = state.map_from_odom
        elif overlay.frame == "robot":
            frame = state.pose
        else:
            frame = Pose(0.0, 0.0, 0.0)

        def place(points: FloatArray) -> list[tuple[int, int]]:
            return view.px(transform_points(frame, np.asarray(points, dtype=float).reshape(-1, 2)))

        for seg in np.asarray(overlay.segments, dtype=float).reshape(-1, 4):
            a, b = place(seg.reshape(2, 2))
            pygame.draw.line(surface, OVERLAY, a, b, 2)
        for p in place(overlay.points) if len(overlay.points) else []:
            pygame.draw.circle(surface, OVERLAY, p, 4, 1)
        if len(overlay.path) > 1:
            pygame.draw.lines(surface, OVERLAY, False, place(overlay.path), 1)
        if overlay.target is not None:
            u, v = place(overlay.target)[0]
            pygame.draw.circle(surface, OVERLAY, (u, v), 6, 2)
            pygame.draw.line(surface, OVERLAY, (u - 8, v), (u + 8, v), 1)
            pygame.draw.line(surface, OVERLAY, (u, v - 8), (u, v + 8), 1)

    def close(self) -> None:
        if self.window is not None:
            pygame = _pygame()
            pygame.display.quit()
            self.window = None
