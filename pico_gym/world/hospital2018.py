"""The 2018 hospital: an unknown building to explore, with a parking wall at the hallway's end.

Rules (docs/facts/hospital-facts.md 1.10 and 3): a hallway U(1.2, 1.8) m wide, straight (I) or with one bend
(L); 3-6 rectangular rooms of 2.0-4.5 m off both sides of it, 0.2 m walls apart; door openings
U(0.5, 1.5) m, at least 0.3 m from the corners of the wall they are in. The rooms and doors form a
tree ("it is not possible to drive in a loop"): every room has exactly one door towards the
hallway, either to the hallway itself or to its neighbour in the row (with `nested_probability`),
so a room may be reached through up to `max_depth` - 1 other rooms ("rooms can be nested"), and a
room may have several doors (its own and those of the rooms behind it). The parking wall is the
hallway's end wall at the start of its first leg: PICO starts in front of it, facing away.

Layouts (`ExploreHospitalConfig.layout`) beyond the rules' default, each stressing the search in
one way: "comb" (the rooms hang off a side corridor that branches from the hallway, like the teeth
of a comb), "deep-L" (an L hallway whose rooms all lie at the far end of its far leg) and "nested"
(some room is reached through two others).

Every draw comes from the generator passed in.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pico_gym.types import FloatArray
from pico_gym.validate import number, span
from pico_gym.world.hospital import (
    WALL_M,
    Rect,
    _assemble,
    _hallway_legs,
    hallway_door,
    outline_segments,
    row_rooms,
    shared_wall_door,
)
from pico_gym.world.map import Map

LAYOUTS = ("default", "comb", "deep-L", "nested")
# A comb's side corridor: its width and length ranges [m].
COMB_CORRIDOR_M = ((1.0, 1.4), (6.0, 9.0))
# A deep L's far leg: its length range [m]; its rooms lie beyond this fraction of it.
DEEP_LEG_M, DEEP_FROM = (7.0, 10.0), 0.5


@dataclass(frozen=True)
class ExploreHospitalConfig:
    """Ranges the 2018 hospital generator draws from (uniformly unless said otherwise).

    Attributes:
        hallway_width_m: the hallway's width [m].
        hallway_shapes: "I" (straight) and/or "L" (one bend).
        n_rooms: range of the number of rooms.
        room_side_m: range of a room's width along the hallway and its depth [m].
        door_width_m: range of a door opening's width [m].
        door_corner_margin_m: a door keeps this far from the corners of its wall [m].
        nested_probability: chance that a room's door leads to its row neighbour (nesting) rather
            than to the hallway.
        max_depth: the most doors on the way from the hallway into any room.
        layout: "default" (the rules' rows of rooms along the hallway), "comb", "deep-L" or
            "nested" (module docstring).
    """

    hallway_width_m: tuple[float, float] = (1.2, 1.8)
    hallway_shapes: tuple[str, ...] = ("I", "L")
    n_rooms: tuple[int, int] = (3, 6)
    room_side_m: tuple[float, float] = (2.0, 4.5)
    door_width_m: tuple[float, float] = (0.5, 1.5)
    door_corner_margin_m: float = 0.3
    nested_probability: float = 0.4
    max_depth: int = 3
    layout: str = "default"

    def __post_init__(self) -> None:
        if self.layout not in LAYOUTS:
            raise ValueError(f"ExploreHospitalConfig.layout must be one of {LAYOUTS}, got {self.layout!r}")
        span("ExploreHospitalConfig.hallway_width_m", self.hallway_width_m, 1.0, 5.0)
        span("ExploreHospitalConfig.n_rooms", self.n_rooms, 1, 20, integer=True)
        span("ExploreHospitalConfig.room_side_m", self.room_side_m, 2.0, 20.0)
        span("ExploreHospitalConfig.door_width_m", self.door_width_m, 0.5, 3.0)
        if not set(self.hallway_shapes) <= {"I", "L"} or not self.hallway_shapes:
            raise ValueError(f"ExploreHospitalConfig.hallway_shapes must be among 'I', 'L', got {self.hallway_shapes}")
        number("ExploreHospitalConfig.door_corner_margin_m", self.door_corner_margin_m, 0.0, 1.0, unit=" m")
        number("ExploreHospitalConfig.nested_probability", self.nested_probability, 0.0, 1.0)
        number("ExploreHospitalConfig.max_depth", self.max_depth, 1, 10, integer=True)


@dataclass(frozen=True)
class GeneratedExploreHospital:
    """A generated 2018 hospital: its map, and the parts it was built from.

    Attributes:
        map: walls (the outline of the free space), the door openings as `doors`, a `start_area`
            (where the start centre is drawn) and `extra["parking_wall"]`.
        hallway: the hallway's legs.
        rooms: the rooms.
        doors: the door openings; `doors[i]` leads into `rooms[i]` (one per room).
        parent: the room each room's door leads from (-1: the hallway).
        depth: the doors on the way from the hallway into each room.
        parking_wall: (2, 2) end points of the parking wall.
        shape: "I" or "L".
    """

    map: Map
    hallway: tuple[Rect, ...]
    rooms: tuple[Rect, ...]
    doors: tuple[Rect, ...]
    parent: tuple[int, ...]
    depth: tuple[int, ...]
    parking_wall: FloatArray
    shape: str


def generate_explore_hospital(
    rng: np.random.Generator, config: ExploreHospitalConfig | None = None
) -> GeneratedExploreHospital:
    """Draw a hospital by the 2018 rules (module docstring).

    Raises:
        RuntimeError: if no hospital satisfying the rules was found in 200 tries.
    """
    cfg = config or ExploreHospitalConfig()
    for _ in range(200):
        built = _try_generate(rng, cfg)
        if built is not None:
            return built
    raise RuntimeError(f"no 2018 hospital satisfies {cfg} (200 tries)")


def _try_generate(rng: np.random.Generator, cfg: ExploreHospitalConfig) -> GeneratedExploreHospital | None:
    if cfg.layout == "default":
        shape = str(cfg.hallway_shapes[int(rng.integers(len(cfg.hallway_shapes)))])
        legs = _hallway_legs(rng, cfg, shape)
        target = int(rng.integers(cfg.n_rooms[0], cfg.n_rooms[1] + 1))
        rooms, attach, row_of = row_rooms(rng, legs, target, cfg.room_side_m)
    else:
        shape, legs, rooms, attach, row_of = _layout(rng, cfg)
    if len(rooms) < cfg.n_rooms[0]:
        return None
    margin = cfg.door_corner_margin_m
    parent: list[int] = []
    depth: list[int] = []
    doors: list[Rect] = []
    previous: dict[tuple[int, str], int] = {}  # the last room placed in each row
    for i, (room, (k, side), row) in enumerate(zip(rooms, attach, row_of, strict=True)):
        door = None
        before = previous.get((k, side))
        if (
            before is not None
            and row[2] > 0
            and depth[before] < cfg.max_depth
            and rng.random() < cfg.nested_probability
        ):
            door = shared_wall_door(rng, rooms[before], room, cfg.door_width_m, margin)
            if door is not None:
                parent.append(before)
                depth.append(depth[before] + 1)
        if door is None:
            door = hallway_door(rng, room, legs[k], side, cfg.door_width_m, margin)
            if door is None:
                return None
            parent.append(-1)
            depth.append(1)
        doors.append(door)
        previous[(k, side)] = i
    if cfg.layout == "nested" and max(depth) < 3:
        return None  # some room must be reached through two others
    walls = outline_segments(list(legs) + rooms + doors)
    x0, y0, _, y1 = legs[0]
    # From the top end to the bottom one: the building lies on the wall's left.
    parking_wall = np.array([(x0, y1), (x0, y0)], dtype=np.float64)
    # Where the start centre is drawn: 0.35-1.0 m from the parking wall, 0.3 m off the side walls.
    start_area = (x0 + 0.35, y0 + 0.3, x0 + 1.0, y1 - 0.3)
    world = _assemble(walls, [], start_area, doors)
    world = Map(
        points=world.points,
        walls=world.walls,
        start_area=world.start_area,
        doors=world.doors,
        name="generated 2018 hospital",
        extra={"parking_wall": parking_wall.tolist()},
    )
    return GeneratedExploreHospital(
        world, tuple(legs), tuple(rooms), tuple(doors), tuple(parent), tuple(depth), parking_wall, shape
    )


def _layout(
    rng: np.random.Generator, cfg: ExploreHospitalConfig
) -> tuple[str, list[Rect], list[Rect], list[tuple[int, str]], list[tuple[int, str, int]]]:
    """The hallway and rooms of a layout other than the default: (shape, legs, rooms, each
    room's (leg, side), each room's (leg, side, position in its row))."""
    width = float(rng.uniform(*cfg.hallway_width_m))
    target = int(rng.integers(cfg.n_rooms[0], cfg.n_rooms[1] + 1))
    if cfg.layout == "nested":
        # Long rows, so that a room can sit behind two others.
        length = float(rng.uniform(9.0, 13.0))
        legs: list[Rect] = [(0.0, 0.0, length, width)]
        rooms, attach, row_of = row_rooms(rng, legs, target, cfg.room_side_m)
        return "I", legs, rooms, attach, row_of
    if cfg.layout == "comb":
        # The hallway from the parking wall, and a side corridor branching up from it: the rooms
        # hang off the side corridor only (the teeth).
        length = float(rng.uniform(6.0, 9.0))
        side_w = float(rng.uniform(*COMB_CORRIDOR_M[0]))
        side_len = float(rng.uniform(*COMB_CORRIDOR_M[1]))
        at = float(rng.uniform(2.5, length - side_w))
        legs = [(0.0, 0.0, length, width), (at, width, at + side_w, width + side_len)]
        teeth = (at, width + WALL_M, at + side_w, width + side_len)  # rows start a wall above the hallway
        rooms, attach, row_of = row_rooms(rng, [teeth], target, cfg.room_side_m)
        return "comb", legs, rooms, [(1, side) for _, side in attach], [(1, side, n) for _, side, n in row_of]
    # deep-L: the rooms lie along the far part of a long far leg.
    length = float(rng.uniform(6.0, 9.0))
    up = float(rng.uniform(*DEEP_LEG_M))
    legs = [(0.0, 0.0, length, width), (length - width, width, length, width + up)]
    far = (length - width, width + DEEP_FROM * up, length, width + up)
    rooms, attach, row_of = row_rooms(rng, [far], target, cfg.room_side_m)
    return "deep-L", legs, rooms, [(1, side) for _, side in attach], [(1, side, n) for _, side, n in row_of]
