"""The pico-gym map: a JSON file (a superset of the course's hospital maps) to a `Map` value.

The format is documented in maps/README.md (and docs/facts/map-format.md). Every course JSON map
loads as it is; heightmap images load through the "heightmap" key or directly with
`load_map("some.pgm")`. Every problem with a file raises `MapError` naming the file and the key
or index at fault.
"""

from __future__ import annotations

import json
import math
import os
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import Any

import numpy as np

from pico_gym.jsonfile import JsonError, read_json
from pico_gym.robot import PICO_OUTLINE
from pico_gym.types import FloatArray, Pose, Segments
from pico_gym.world import geometry
from pico_gym.world.heightmap import (
    COURSE_RESOLUTION_M,
    FREE_OCCUPANCY,
    MAX_IMAGE_PIXELS,
    HeightmapGeometry,
    ImageError,
    heightmap_geometry,
    read_grey,
)
from pico_gym.world.map_server import (
    MapServerError,
    MapServerSettings,
    course_grey,
    occupancy_values,
    read_channels,
    read_metadata,
)
from pico_gym.world.movers import MoverRecord, mover_problem, mover_record

FORMAT_VERSION = 1
IMAGE_SUFFIXES = (".png", ".pgm", ".pbm", ".ppm", ".bmp", ".jpg", ".jpeg", ".gif", ".tif", ".tiff")
_KNOWN_KEYS = {
    "version",
    "name",
    "points",
    "walls",
    "cabinets",
    "start_area",
    "start",
    "doors",
    "finish",
    "start_pose",
    "obstacles",
    "movers",
    "heightmap",
    "map_server",
    "simulator_frame",
}
YAML_SUFFIXES = (".yaml", ".yml")


# A budget: a map's points may span at most this much on either axis [m] (its grids grow with the
# square of it; the course's hospitals are under 20 m).
MAX_MAP_SIDE_M = 200.0


class MapError(ValueError):
    """A map file is missing, unreadable or inconsistent; the message names the file and the key."""


@dataclass(frozen=True, eq=False)
class Heightmap:
    """A heightmap reference: the image path (relative to the map file's folder), its placement
    and, for a ROS map_server map, how its pixels are read (`map_server`)."""

    image: str
    resolution: float = COURSE_RESOLUTION_M
    origin: tuple[float, float] | None = None
    simplify_m: float | None = None
    yaw: float = 0.0
    map_server: MapServerSettings | None = None
    yaml: str | None = None  # the map_server YAML, as the map file names it


@dataclass(frozen=True, eq=False)
class Map:
    """A world: wall geometry plus the task annotations of the map file.

    Index lists (walls, cabinets, start_area, doors) refer to `points`. Geometry from a heightmap
    is available through the segment properties.
    """

    points: FloatArray = field(default_factory=lambda: np.zeros((0, 2)))
    walls: np.ndarray = field(default_factory=lambda: np.zeros((0, 2), dtype=np.int64))
    cabinets: tuple[np.ndarray, ...] = ()
    start_area: tuple[np.ndarray, ...] = ()
    doors: tuple[np.ndarray, ...] = ()
    name: str = ""
    finish: FloatArray | None = None
    start_pose: Pose | None = None
    obstacles: tuple[FloatArray, ...] = ()
    movers: tuple[MoverRecord, ...] = ()
    heightmap: Heightmap | None = None
    extra: dict[str, Any] = field(default_factory=dict)
    source: Path | None = None
    simulator_frame: tuple[float, float, float] = (0.0, 0.0, 0.0)

    def from_simulator(self, pose: tuple[float, float, float]) -> Pose:
        """A pose in the course simulator's frame (its config's poses) in the map frame."""
        fx, fy, fth = self.simulator_frame
        c, s = math.cos(fth), math.sin(fth)
        x, y, th = pose
        return Pose(fx + c * x - s * y, fy + s * x + c * y, math.remainder(th + fth, 2 * math.pi))

    # --- geometry -------------------------------------------------------------------------
    @cached_property
    def _heightmap_geometry(self) -> HeightmapGeometry | None:
        if self.heightmap is None:
            return None
        base = self.source.parent if self.source is not None else Path.cwd()
        path = (base / self.heightmap.image).resolve()
        where = self.source or path
        if not path.is_file():
            raise MapError(f"{where}: heightmap.image: file not found: {path}")
        hm = self.heightmap
        try:
            if hm.map_server is None:
                grey = read_grey(path)
            else:
                pixels, has_alpha = read_channels(path, MAX_IMAGE_PIXELS)
                grey = course_grey(occupancy_values(pixels, has_alpha, hm.map_server), hm.map_server.unknown)
        except (ImageError, MapServerError) as error:
            raise MapError(f"{where}: {'map_server' if hm.map_server else 'heightmap'}.image {path}: {error}") from None
        key = "map_server" if hm.map_server else "heightmap"
        rows, cols = grey.shape
        if max(rows, cols) * hm.resolution > MAX_MAP_SIDE_M:
            raise MapError(
                f"{where}: {key}.resolution: {hm.resolution} m per pixel makes the {cols} x {rows} image "
                f"{cols * hm.resolution:,.0f} x {rows * hm.resolution:,.0f} m; a map spans at most "
                f"{MAX_MAP_SIDE_M:.0f} m"
            )
        if not ((255.0 - grey.astype(np.float64)) / 255.0 < FREE_OCCUPANCY).any():
            raise MapError(f"{where}: {key}.image {path}: no free floor: every pixel is an obstacle or a door")
        try:
            return heightmap_geometry(grey, hm.resolution, hm.origin, hm.simplify_m, yaw=hm.yaw)
        except ImageError as error:
            raise MapError(f"{where}: heightmap.image {path}: {error}") from None

    def _index_segments(self, pairs: np.ndarray) -> Segments:
        pairs = np.asarray(pairs, dtype=np.int64).reshape(-1, 2)
        return np.hstack([self.points[pairs[:, 0]], self.points[pairs[:, 1]]]).reshape(-1, 4)

    @cached_property
    def wall_segments(self) -> Segments:
        """Walls the LRF sees: the walls and cabinets of the file plus visible heightmap blocks."""
        parts = [self._index_segments(self.walls)]
        parts += [self._index_segments(c) for c in self.cabinets]
        if self._heightmap_geometry is not None:
            parts.append(self._heightmap_geometry.visible)
        return np.ascontiguousarray(np.vstack(parts)) if parts else np.zeros((0, 4))

    @cached_property
    def structure_segments(self) -> Segments:
        """The building alone: the file's walls plus visible heightmap blocks (no cabinets)."""
        parts = [self._index_segments(self.walls)]
        if self._heightmap_geometry is not None:
            parts.append(self._heightmap_geometry.visible)
        return np.ascontiguousarray(np.vstack(parts))

    @cached_property
    def structure_one_sided(self) -> np.ndarray:
        """Per segment of `structure_segments`: a closed outline directed with the free side on its
        left (fitted heightmap outlines), which the LRF may skip when seen from behind."""
        flags = [np.zeros(len(self.walls), dtype=bool)]
        geo = self._heightmap_geometry
        if geo is not None:
            flags.append(np.full(len(geo.visible), geo.visible_one_sided, dtype=bool))
        return np.concatenate(flags)

    @cached_property
    def cabinet_segments(self) -> Segments:
        """The cabinets' outlines (each cabinet's front first)."""
        if not self.cabinets:
            return np.zeros((0, 4))
        return np.ascontiguousarray(np.vstack([self._index_segments(c) for c in self.cabinets]))

    @cached_property
    def low_segments(self) -> Segments:
        """Solid obstacles below the laser plane (from heightmaps): bumped into, never seen."""
        geo = self._heightmap_geometry
        return np.zeros((0, 4)) if geo is None else np.ascontiguousarray(geo.low)

    @cached_property
    def door_segments(self) -> tuple[Segments, ...]:
        """One segment array per door (closed, the door blocks the opening)."""
        doors = [self._index_segments(d) for d in self.doors]
        if self._heightmap_geometry is not None:
            doors += list(self._heightmap_geometry.doors)
        return tuple(doors)

    @cached_property
    def obstacle_segments(self) -> Segments:
        """Edges of the static obstacles (in the world, not in the map an agent is given)."""
        if not self.obstacles:
            return np.zeros((0, 4))
        return np.ascontiguousarray(np.vstack([geometry.polygon_to_segments(p) for p in self.obstacles]))

    def seen_segments(self, doors_closed: bool = True) -> Segments:
        """All geometry the LRF sees: walls, cabinets, obstacles and (closed) doors."""
        parts = [self.wall_segments, self.obstacle_segments]
        if doors_closed:
            parts += list(self.door_segments)
        return np.ascontiguousarray(np.vstack(parts))

    def solid_segments(self, doors_closed: bool = True) -> Segments:
        """All geometry the robot collides with: what the LRF sees plus low obstacles."""
        return np.ascontiguousarray(np.vstack([self.seen_segments(doors_closed), self.low_segments]))

    @property
    def bounds(self) -> tuple[float, float, float, float]:
        """(xmin, ymin, xmax, ymax) of all solid geometry and the finish line."""
        segs = self.solid_segments()
        xs = np.concatenate([segs[:, 0], segs[:, 2]])
        ys = np.concatenate([segs[:, 1], segs[:, 3]])
        if self.finish is not None:
            xs = np.concatenate([xs, self.finish[:, 0]])
            ys = np.concatenate([ys, self.finish[:, 1]])
        return float(xs.min()), float(ys.min()), float(xs.max()), float(ys.max())

    def polygon(self, pairs: np.ndarray) -> FloatArray:
        """Ordered vertices of a closed polygon given as [i, j] segments (cabinets, start areas)."""
        return self.points[_cycle_order(np.asarray(pairs))]


# --- loading ------------------------------------------------------------------------------


def _fail(where: Any, key: str, message: str) -> MapError:
    return MapError(f"{where}: {key}: {message}")


def _number(value: Any, where: Any, key: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise _fail(where, key, f"expected a finite number, got {value!r}")
    return float(value)


def _xy(value: Any, where: Any, key: str) -> tuple[float, float]:
    if isinstance(value, dict):
        if "x" not in value or "y" not in value:
            raise _fail(where, key, f"a point needs keys 'x' and 'y', got {sorted(value)}")
        return _number(value["x"], where, key + ".x"), _number(value["y"], where, key + ".y")
    if isinstance(value, (list, tuple)) and len(value) == 2:
        return _number(value[0], where, key + "[0]"), _number(value[1], where, key + "[1]")
    raise _fail(where, key, f"expected {{'x': .., 'y': ..}} or [x, y], got {value!r}")


def _pairs(value: Any, n_points: int, where: Any, key: str) -> np.ndarray:
    if not isinstance(value, list):
        raise _fail(where, key, f"expected a list of [i, j] index pairs, got {type(value).__name__}")
    out = np.zeros((len(value), 2), dtype=np.int64)
    for k, pair in enumerate(value):
        if not (
            isinstance(pair, list)
            and len(pair) == 2
            and all(isinstance(i, int) and not isinstance(i, bool) for i in pair)
        ):
            raise _fail(where, f"{key}[{k}]", f"expected a pair of point indices [i, j], got {pair!r}")
        for i in pair:
            if not 0 <= i < n_points:
                raise _fail(
                    where,
                    f"{key}[{k}]",
                    f"point index {i} out of range (the map has {n_points} points: 0..{n_points - 1})",
                )
        out[k] = pair
    return out


def _cycle_order(pairs: np.ndarray) -> np.ndarray:
    """Vertex order of the closed cycle formed by index pairs; ValueError if they do not close."""
    if len(pairs) < 3:
        raise ValueError(f"a closed polygon needs at least 3 segments, got {len(pairs)}")
    neighbours: dict[int, list[int]] = {}
    for i, j in pairs.tolist():
        neighbours.setdefault(i, []).append(j)
        neighbours.setdefault(j, []).append(i)
    open_ends = [v for v, ns in neighbours.items() if len(ns) != 2]
    if open_ends:
        raise ValueError(
            f"segments do not form a closed polygon: point {open_ends[0]} "
            f"is used by {len(neighbours[open_ends[0]])} segment(s), not 2"
        )
    order = [int(pairs[0, 0])]
    prev, cur = None, int(pairs[0, 0])
    while True:
        a, b = neighbours[cur]
        nxt = b if a == prev else a
        if nxt == order[0]:
            break
        order.append(nxt)
        prev, cur = cur, nxt
    if len(order) != len(neighbours):
        raise ValueError("segments form more than one loop, not one closed polygon")
    return np.array(order)


def _polygons(value: Any, n_points: int, where: Any, key: str) -> tuple[np.ndarray, ...]:
    if not isinstance(value, list):
        raise _fail(where, key, f"expected a list of polygons, got {type(value).__name__}")
    polys = []
    for k, poly in enumerate(value):
        pairs = _pairs(poly, n_points, where, f"{key}[{k}]")
        try:
            _cycle_order(pairs)
        except ValueError as error:
            raise _fail(where, f"{key}[{k}]", str(error)) from None
        polys.append(pairs)
    return tuple(polys)


def map_from_dict(data: Any, source: Path | None = None, allow_outside: bool = False) -> Map:
    """Build a `Map` from the parsed JSON of a map file; `source` is used in messages and paths.

    Files the map references (a heightmap or map_server image, a map_server YAML, a mover config)
    must lie in the map file's folder or below it, unless `allow_outside`."""
    where = source or "<map>"
    if not isinstance(data, dict):
        raise MapError(f"{where}: a map file must hold a JSON object, got {type(data).__name__}")
    version = data.get("version", FORMAT_VERSION)
    if type(version) is not int or version != FORMAT_VERSION:
        raise _fail(where, "version", f"unsupported version {version!r} (this pico-gym reads {FORMAT_VERSION})")
    if "walls" not in data and "heightmap" not in data and "map_server" not in data:
        raise MapError(
            f"{where}: missing key 'walls' (a map needs 'walls' with 'points', a 'heightmap' or a 'map_server' map)"
        )
    if "heightmap" in data and "map_server" in data:
        raise _fail(where, "map_server", "give a 'heightmap' or a 'map_server' map, not both")
    points = _points(data, where)
    n = len(points)
    start_key = "start_area" if "start_area" in data else "start"
    name = data.get("name", source.stem if source is not None else "")
    if not isinstance(name, str):
        raise _fail(where, "name", f"expected a string, got {name!r}")
    start_pose = _start_pose(data["start_pose"], where) if "start_pose" in data else None
    frame = _frame(data["simulator_frame"], where, "simulator_frame") if "simulator_frame" in data else (0.0, 0.0, 0.0)
    result = Map(
        points=points,
        walls=_pairs(data.get("walls", []), n, where, "walls"),
        cabinets=_polygons(data.get("cabinets", []), n, where, "cabinets"),
        start_area=_polygons(data.get(start_key, []), n, where, start_key),
        doors=_polygons(data.get("doors", []), n, where, "doors"),
        name=name,
        finish=_finish(data["finish"], where) if "finish" in data else None,
        start_pose=start_pose,
        obstacles=_obstacles(data.get("obstacles", []), where),
        movers=tuple(_movers(data.get("movers", []), source, where, allow_outside, frame)),
        heightmap=_image_reference(data, source, where, allow_outside),
        extra={k: v for k, v in data.items() if k not in _KNOWN_KEYS},
        source=source,
        simulator_frame=frame,
    )
    result.wall_segments  # noqa: B018  (reads the heightmap now, so its errors surface at load time)
    if start_pose is not None:
        check_start_pose(result, where)
    check_movers(result, where)
    return result


def check_movers(world: Map, where: Any, key: str = "movers") -> None:
    """Refuse movers that cannot walk on the map (MapError naming `where` and the mover): one that
    starts or ends outside the map, or whose way meets a wall, a cabinet or an obstacle."""
    if not world.movers:
        return
    static = np.vstack([world.structure_segments, world.cabinet_segments, world.obstacle_segments])
    for k, m in enumerate(world.movers):
        problem = mover_problem(m, static, world.bounds)
        if problem is not None:
            raise _fail(where, f"{key}[{k}]", problem)


def _points(data: dict[str, Any], where: Any) -> FloatArray:
    """The map's points, (n, 2), within `MAX_MAP_SIDE_M` of each other."""
    points_raw = data.get("points", [])
    if not isinstance(points_raw, list):
        raise _fail(where, "points", f"expected a list, got {type(points_raw).__name__}")
    if "walls" in data and "points" not in data:
        raise MapError(f"{where}: missing key 'points' (needed by 'walls')")
    points = np.array([_xy(p, where, f"points[{i}]") for i, p in enumerate(points_raw)], dtype=np.float64).reshape(
        -1, 2
    )
    if len(points):
        span = points.max(axis=0) - points.min(axis=0)
        if span.max() > MAX_MAP_SIDE_M:
            raise _fail(
                where,
                "points",
                f"the map spans {span[0]:,.1f} x {span[1]:,.1f} m; the limit is {MAX_MAP_SIDE_M:g} m a side",
            )
    return points


def _finish(f: Any, where: Any) -> FloatArray:
    """The finish line, (2, 2), its ends apart."""
    if not (isinstance(f, list) and len(f) == 2):
        raise _fail(where, "finish", f"expected [[x1, y1], [x2, y2]], got {f!r}")
    finish = np.array([_xy(p, where, f"finish[{i}]") for i, p in enumerate(f)])
    if np.allclose(finish[0], finish[1]):
        raise _fail(where, "finish", "the two end points coincide")
    return finish


def _start_pose(sp: Any, where: Any) -> Pose:
    """A start pose {"x", "y", "theta"}."""
    if not isinstance(sp, dict):
        raise _fail(where, "start_pose", f"expected {{'x', 'y', 'theta'}}, got {sp!r}")
    for name in ("x", "y", "theta"):
        if name not in sp:
            raise _fail(where, "start_pose", f"missing key '{name}'")
    return Pose(*(_number(sp[name], where, f"start_pose.{name}") for name in ("x", "y", "theta")))


def _obstacles(value: Any, where: Any) -> tuple[FloatArray, ...]:
    """The unknown static obstacles: polygons of 3 or more vertices."""
    if not isinstance(value, list):
        raise _fail(where, "obstacles", f"expected a list of {{'polygon': [[x, y], ...]}}, got {value!r:.60}")
    obstacles = []
    for k, ob in enumerate(value):
        poly = ob.get("polygon") if isinstance(ob, dict) else None
        if not isinstance(poly, list) or len(poly) < 3:
            raise _fail(where, f"obstacles[{k}]", "expected {'polygon': [[x, y], ...]} with at least 3 vertices")
        obstacles.append(np.array([_xy(p, where, f"obstacles[{k}].polygon[{i}]") for i, p in enumerate(poly)]))
    return tuple(obstacles)


def _inside(base: Path, path: Path, where: Any, key: str, allow_outside: bool) -> Path:
    """`path` resolved; refused unless it lies in `base` (the map file's folder) or below it."""
    resolved = path.resolve()
    if not allow_outside and not resolved.is_relative_to(base.resolve()):
        raise _fail(
            where,
            key,
            f"{path} is outside the map file's folder {base.resolve()}: a map may reference files in its own "
            "folder only (load_map(path, allow_outside=True) lifts that for a map you trust)",
        )
    return resolved


def _image_reference(data: dict[str, Any], source: Path | None, where: Any, allow_outside: bool) -> Heightmap | None:
    """The map's image: a course heightmap (`heightmap`) or a ROS map_server map (`map_server`)."""
    base = source.parent if source is not None else Path.cwd()
    if "heightmap" in data:
        hm = _heightmap(data["heightmap"], where)
        _inside(base, base / hm.image, where, "heightmap.image", allow_outside)
        return hm
    if "map_server" in data:
        return _map_server(data["map_server"], base, where, allow_outside)
    return None


def _map_server(value: Any, base: Path, where: Any, allow_outside: bool) -> Heightmap:
    """`"map_server": "map.yaml"` or `{"yaml": "map.yaml", "frame": "simulator" | "ros", "unknown":
    "door" | "wall" | "free", "simplify_m": d}`: a ROS map_server map (`pico_gym.world.map_server`)."""
    if isinstance(value, str):
        value = {"yaml": value}
    if not isinstance(value, dict) or not isinstance(value.get("yaml"), str):
        raise _fail(where, "map_server", "expected 'map.yaml' or {'yaml': 'map.yaml', 'frame': 'simulator'}")
    extra = sorted(set(value) - {"yaml", "frame", "unknown", "simplify_m"})
    if extra:
        raise _fail(where, f"map_server.{extra[0]}", "unknown key; the keys are yaml, frame, unknown, simplify_m")
    yaml_path = _inside(base, base / value["yaml"], where, "map_server.yaml", allow_outside)
    if not yaml_path.is_file():
        raise _fail(where, "map_server.yaml", f"file not found: {yaml_path}")
    try:
        settings = read_metadata(yaml_path, value.get("frame", "simulator"), value.get("unknown", "door"))
    except MapServerError as error:
        raise MapError(f"{where}: map_server: {error}") from None
    image = _inside(base, yaml_path.parent / settings.image, where, "map_server image", allow_outside)
    if not image.is_file():
        raise _fail(where, "map_server", f"{yaml_path}: image: file not found: {image}")
    simplify = None
    if value.get("simplify_m") is not None:
        simplify = _number(value["simplify_m"], where, "map_server.simplify_m")
        if not 0 < simplify <= settings.resolution:
            raise _fail(where, "map_server.simplify_m", f"must be in (0, {settings.resolution}], got {simplify}")
    x, y, yaw = settings.placement
    return Heightmap(
        os.path.relpath(image, base.resolve()), settings.resolution, (x, y), simplify, yaw, settings, value["yaml"]
    )


def _heightmap(hm: Any, where: Any) -> Heightmap:
    """A heightmap reference {"image", "resolution", "origin", "simplify_m"}."""
    if not isinstance(hm, dict) or not isinstance(hm.get("image"), str):
        raise _fail(where, "heightmap", "expected {'image': 'path.png', 'resolution': 0.025, 'origin': [x, y]}")
    resolution = _number(hm.get("resolution", COURSE_RESOLUTION_M), where, "heightmap.resolution")
    if resolution <= 0:
        raise _fail(where, "heightmap.resolution", f"must be positive, got {resolution}")
    origin = _xy(hm["origin"], where, "heightmap.origin") if "origin" in hm else None
    simplify = None
    if hm.get("simplify_m") is not None:
        simplify = _number(hm["simplify_m"], where, "heightmap.simplify_m")
        if not 0 < simplify <= resolution:
            raise _fail(where, "heightmap.simplify_m", f"must be in (0, resolution = {resolution}], got {simplify}")
    return Heightmap(hm["image"], resolution, origin, simplify)


def _frame(value: Any, where: Any, key: str) -> tuple[float, float, float]:
    """[x, y, yaw]: a frame's origin and heading in the map."""
    if not (isinstance(value, list) and len(value) == 3):
        raise _fail(where, key, f"expected [x, y, yaw], got {value!r}")
    x, y, yaw = (_number(v, where, f"{key}[{i}]") for i, v in enumerate(value))
    return (x, y, yaw)


def _movers(
    value: Any,
    source: Path | None,
    where: Any,
    allow_outside: bool = False,
    frame: tuple[float, float, float] = (0.0, 0.0, 0.0),
) -> tuple[MoverRecord, ...]:
    """The `movers` key: course records in the map frame, or a course config file placed by a frame.

    `{"config": "hospital_2021_config.json", "frame": [x, y, yaw]}` reads the course simulator's
    config file as it is (its "objects") and converts each pose from the course frame into the map
    frame; `frame` is the course frame's origin and heading in the map (default: the identity).
    """
    if isinstance(value, dict):
        return _movers_from_config(value, source, where, allow_outside, frame)
    if not isinstance(value, list):
        raise _fail(where, "movers", f"expected a list of moving-object records, got {type(value).__name__}")
    out = []
    for k, raw in enumerate(value):
        try:
            out.append(mover_record(raw, f"movers[{k}]"))
        except ValueError as error:
            raise MapError(f"{where}: {error}") from None
    return tuple(out)


def _movers_from_config(
    value: dict[str, Any],
    source: Path | None,
    where: Any,
    allow_outside: bool = False,
    default_frame: tuple[float, float, float] = (0.0, 0.0, 0.0),
) -> tuple[MoverRecord, ...]:
    """`{"config": "file.json", "frame": [x, y, yaw]}`: a course config's objects, placed (without
    `frame`: by the map's `simulator_frame`)."""
    if not isinstance(value.get("config"), str):
        raise _fail(where, "movers", "expected a list of records or {'config': 'file.json', 'frame': [x, y, yaw]}")
    base = source.parent if source is not None else Path.cwd()
    path = _inside(base, base / value["config"], where, "movers.config", allow_outside)
    try:
        config = read_json(path)
    except JsonError as error:
        raise _fail(where, "movers.config", str(error)) from None
    if not isinstance(config, dict) or not isinstance(config.get("objects", []), list):
        raise _fail(where, "movers.config", f"{path}: expected a course config with a list 'objects'")
    fx, fy, fth = _frame(value["frame"], where, "movers.frame") if "frame" in value else default_frame
    c, s = math.cos(fth), math.sin(fth)
    out = []
    for k, raw in enumerate(config.get("objects", [])):
        try:
            rec = mover_record(raw, f"{path}: objects[{k}]")
        except ValueError as error:
            raise MapError(f"{where}: movers.config: {error}") from None

        def place(p: tuple[float, float, float]) -> tuple[float, float, float]:
            return (fx + c * p[0] - s * p[1], fy + s * p[0] + c * p[1], p[2] + fth)

        out.append(
            MoverRecord(
                rec.length,
                rec.width,
                rec.trigger_radius,
                rec.velocity,
                place(rec.init_pose),
                place(rec.final_pose),
                rec.repeat,
            )
        )
    return tuple(out)


def check_start_pose(world: Map, where: Any) -> None:
    """Refuse a map whose start pose puts the robot's footprint into a wall (MapError naming `where`)."""
    if world.start_pose is None:
        return
    footprint = geometry.transform_points(world.start_pose, PICO_OUTLINE)
    solid = world.solid_segments()
    if geometry.polygon_clearance(footprint, solid) <= 0.0:
        x, y, th = world.start_pose
        raise _fail(where, "start_pose", f"the robot at ({x:.3f}, {y:.3f}, {th:.3f}) overlaps a wall")


def load_map(path: str | os.PathLike[str], allow_outside: bool = False) -> Map:
    """Load a map file: pico-gym/course JSON, a course heightmap image (PGM/PNG/...), or a ROS
    map_server metadata YAML (read as the course simulator reads it: `pico_gym.world.map_server`).

    Files a map references must lie in its folder or below it, unless `allow_outside`.

    Raises:
        MapError: naming the file and the key or index at fault.
    """
    path = Path(path)
    if path.is_dir():
        raise MapError(f"{path}: a folder, not a map file")
    if not path.is_file():
        raise MapError(f"{path}: no such map file")
    if path.suffix.lower() in IMAGE_SUFFIXES:
        return map_from_dict({"name": path.stem, "heightmap": {"image": path.name}}, path)
    if path.suffix.lower() in YAML_SUFFIXES:
        return map_from_dict({"name": path.stem, "map_server": path.name}, path)
    try:
        data = read_json(path)
    except JsonError as error:
        raise MapError(str(error)) from None
    return map_from_dict(data, path, allow_outside)


def map_to_dict(world: Map, relative_to: Path | None = None) -> dict[str, Any]:
    """The JSON object of a map. Heightmap paths are rewritten relative to `relative_to`."""
    data: dict[str, Any] = {"version": FORMAT_VERSION}
    if world.name:
        data["name"] = world.name
    data["points"] = [[float(x), float(y)] for x, y in world.points]
    data["walls"] = world.walls.tolist()
    if world.cabinets:
        data["cabinets"] = [c.tolist() for c in world.cabinets]
    if world.start_area:
        data["start_area"] = [s.tolist() for s in world.start_area]
    if world.doors:
        data["doors"] = [d.tolist() for d in world.doors]
    if world.finish is not None:
        data["finish"] = world.finish.tolist()
    if world.start_pose is not None:
        data["start_pose"] = dict(zip(("x", "y", "theta"), map(float, world.start_pose), strict=True))
    if world.obstacles:
        data["obstacles"] = [{"polygon": p.tolist()} for p in world.obstacles]
    if world.movers:
        data["movers"] = [m.to_dict() for m in world.movers]
    if world.simulator_frame != (0.0, 0.0, 0.0):
        data["simulator_frame"] = list(world.simulator_frame)
    if world.heightmap is not None:
        key = "map_server" if world.heightmap.map_server is not None else "heightmap"
        data[key] = _heightmap_to_dict(world, world.heightmap, relative_to)
    data.update(world.extra)
    return data


def _heightmap_to_dict(world: Map, heightmap: Heightmap, relative_to: Path | None) -> dict[str, Any]:
    if heightmap.map_server is not None and heightmap.yaml is not None:
        yaml = heightmap.yaml
        if world.source is not None and relative_to is not None:
            yaml = os.path.relpath((world.source.parent / yaml).resolve(), relative_to.resolve())
        ms: dict[str, Any] = {
            "yaml": yaml,
            "frame": heightmap.map_server.frame,
            "unknown": heightmap.map_server.unknown,
        }
        if heightmap.simplify_m is not None:
            ms["simplify_m"] = heightmap.simplify_m
        return ms
    image = heightmap.image
    if world.source is not None and relative_to is not None:
        image = os.path.relpath((world.source.parent / image).resolve(), relative_to.resolve())
    hm: dict[str, Any] = {"image": image, "resolution": heightmap.resolution}
    if heightmap.origin is not None:
        hm["origin"] = list(heightmap.origin)
    if heightmap.simplify_m is not None:
        hm["simplify_m"] = heightmap.simplify_m
    return hm


def save_map(world: Map, path: str | os.PathLike[str]) -> None:
    """Write a map as a pico-gym JSON map file."""
    path = Path(path)
    path.write_text(json.dumps(map_to_dict(world, relative_to=path.parent), indent=1) + "\n")


def maps_equal(a: Map, b: Map) -> bool:
    """True when two maps hold the same content (the source path aside)."""
    root = Path("/")  # heightmap paths compared as resolved paths, whatever file they were written in
    return map_to_dict(a, root) == map_to_dict(b, root) and np.array_equal(a.wall_segments, b.wall_segments)
