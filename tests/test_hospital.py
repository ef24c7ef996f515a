"""PicoHospital-v0: arrival rule, movers, doors, boxes, the given map, the LRF, bumps by kind, the
generator, bad input."""

from __future__ import annotations

import json
import math
from collections import deque

import gymnasium as gym
import numpy as np
import pytest

import pico_gym  # noqa: F401
from pico_gym.sensors.lrf import lrf_ranges
from pico_gym.types import Pose
from pico_gym.world import geometry
from pico_gym.world.catalog import load_shipped
from pico_gym.world.hospital import CABINET_SIDE_M, Cabinet, HospitalConfig, generate_hospital
from pico_gym.world.map import MapError, load_map
from pico_gym.world.movers import MoverRecord, Movers

QUIET = {"n_boxes": (0, 0), "n_movers": (0, 0), "n_closed_doors": (0, 0), "noise_m": 0.0}
UP = math.pi / 2


def hospital(**kwargs: object) -> gym.Env:
    return gym.make("PicoHospital-v0", map="hospital_2019", **{**QUIET, **kwargs})


def stand(env: gym.Env, steps: int) -> dict:
    info = {}
    for _ in range(steps):
        _, _, terminated, truncated, info = env.step(np.zeros(env.action_space.shape))
        if terminated or truncated:
            break
    return info


# --- the arrival rule ------------------------------------------------------------------------


def test_arrival_counts_after_the_dwell_in_the_square_facing_the_front() -> None:
    env = hospital()
    _, info = env.reset(seed=0, options={"cabinet_order": [0], "start_pose": (0.5, 3.15, UP)})
    assert info["cabinets_done"] == 0 and info["arrival"]["in_square"]
    info = stand(env, 4)  # 0.4 s: not yet
    assert info["cabinets_done"] == 0
    _, reward, terminated, _, info = env.step(np.zeros(3))  # 0.5 s
    assert info["cabinets_done"] == 1 and terminated and info["is_success"]
    assert info["termination_reason"] == "done" and info["reward_terms"]["cabinet"] == 10.0


@pytest.mark.parametrize(
    "pose", [(0.5, 2.85, UP), (0.5, 3.15, UP + math.radians(20)), (0.5, 3.15, UP - math.radians(20))]
)
def test_no_arrival_outside_the_square_or_not_facing(pose: tuple) -> None:
    env = hospital()
    env.reset(seed=0, options={"cabinet_order": [0], "start_pose": pose})
    info = stand(env, 20)
    assert info["cabinets_done"] == 0 and not info["is_success"]


def test_cabinets_count_only_in_order() -> None:
    env = hospital()
    env.reset(seed=0, options={"cabinet_order": [1, 0], "start_pose": (0.5, 3.15, UP)})  # at cabinet 0
    info = stand(env, 20)
    assert info["cabinets_done"] == 0 and info["next_cabinet"] == 1


def test_announce_mode_counts_announcements_and_false_ones() -> None:
    env = hospital(arrival="announce")
    assert env.action_space.shape == (4,)
    env.reset(seed=0, options={"cabinet_order": [0, 2], "start_pose": (0.5, 3.15, UP)})
    _, _, terminated, _, info = env.step(np.array([0, 0, 0, 0.5]))
    assert info["cabinets_done"] == 1 and not terminated
    _, reward, _, _, info = env.step(np.array([0, 0, 0, 1.0]))  # not at cabinet 2: false
    assert info["false_announcements"] == 1 and info["reward_terms"]["false_announce"] < 0
    env = hospital(arrival="announce", false_announcement="terminate")
    env.reset(seed=0, options={"cabinet_order": [2], "start_pose": (0.5, 3.15, UP)})
    *_, terminated, _, info = env.step(np.array([0, 0, 0, 1.0]))
    assert terminated and info["termination_reason"] == "false_announcement"


def test_cabinet_geometry_of_the_2019_map() -> None:
    world = load_shipped("hospital_2019")
    expected = {
        0: ((0.2, 3.0, 0.6, 3.4), 90),
        1: ((0.2, 0.6, 0.6, 1.0), -90),
        2: ((0.2, 5.4, 0.6, 5.8), 90),
        3: ((6.1, 3.0, 6.5, 3.4), -90),
    }
    for i, (box, face) in expected.items():
        cab = Cabinet.of(world, i)
        square = cab.square
        assert square.min(axis=0) == pytest.approx(box[:2]) and square.max(axis=0) == pytest.approx(box[2:])
        assert math.degrees(cab.facing_rad) == pytest.approx(face)


# --- movers ----------------------------------------------------------------------------------

PERSON = MoverRecord(0.2, 0.4, 2.0, 0.5, (0.0, 0.0, 0.0), (3.0, 0.0, 0.0), repeat=True)


def test_mover_starts_when_triggered_pauses_near_the_robot_and_resumes() -> None:
    m = Movers([PERSON])
    for _ in range(100):
        m.advance(0.01, 5.0, 0.0)  # robot 5 m away: beyond the 2 m trigger
    assert not m.triggered(0) and m.poses()[0, 0] == 0.0
    m.advance(0.01, 1.9, 0.0)  # within the trigger radius: starts, once
    assert m.triggered(0) and m.poses()[0, 0] == pytest.approx(0.005)
    for _ in range(100):
        m.advance(0.01, 20.0, 20.0)  # far again: keeps going (the trigger is once)
    assert m.poses()[0, 0] == pytest.approx(0.505)
    pause = PERSON.pause_radius_m
    assert pause == pytest.approx(math.hypot(0.1, 0.2) + 0.3)
    x = m.poses()[0, 0]
    m.advance(0.01, x + pause - 0.01, 0.0)  # inside the pause radius: waits
    assert m.paused(0) and m.poses()[0, 0] == x
    m.advance(0.01, x + pause + 0.01, 0.0)  # just outside: moves on
    assert not m.paused(0) and m.poses()[0, 0] > x


def test_a_mover_pauses_near_another_robot_while_this_one_glides() -> None:
    # Two robots (pico_gym.multi): the robot that drives the movers glides far away, the other
    # stands in the mover's way; the glide's sub-steps see both, as pymunk's do.
    pause = PERSON.pause_radius_m
    runs = {}
    for glides in (False, True):
        m = Movers([PERSON])
        m.advance(0.01, 1.0, 0.0)  # triggered
        m.other_robots = np.array([[1.0 + pause - 0.01, 0.0]])
        if glides:
            out = np.zeros((4, 4))
            m.glide(20.0, 20.0, 0.0, 0.0, 0.0, 0.0, 400, 0.01, out)  # 4 s: 2 m, were it free
        else:
            for _ in range(400):
                m.advance(0.01, 20.0, 20.0)
        runs[glides] = m.poses()[0, 0]
    # Walked up to the other robot's pause radius (x = 0.99), and waits there.
    assert runs[True] == runs[False] and 0.98 < runs[True] <= 1.0


def test_mover_ping_pongs_with_repeat_and_stops_without() -> None:
    m = Movers([PERSON])
    xs = []
    for _ in range(2000):
        m.advance(0.01, 20.0, 20.0) if m.triggered(0) else m.advance(0.01, 0.5, 0.0)
        xs.append(m.poses()[0, 0])
    assert max(xs) == pytest.approx(2.9, abs=0.01) and min(xs[600:]) < 0.2  # turns within 0.1 m, comes back
    once = Movers([MoverRecord(1.0, 0.5, 2.0, 0.6, (0.0, 0.0, 0.0), (3.0, 0.0, 0.0), repeat=False)])
    for _ in range(2000):
        once.advance(0.01, 0.5 if not once.triggered(0) else 30.0, 0.0)
    assert once.finished(0) and once.poses()[0, 0] == pytest.approx(2.9, abs=0.01)


def test_a_standing_robot_is_never_hit_by_a_mover() -> None:
    # A cart driving straight at the robot standing in the hallway, as in the 2021 config.
    env = gym.make("PicoHospital-v0", map=_hospital_with([CART]), **QUIET)
    env.reset(seed=0, options={"cabinet_order": [3], "start_pose": (3.5, 3.0, 0.0)})
    info = stand(env, 400)
    assert info["bumps"] == 0 and info["termination_reason"] == "idle"
    cart_y = info["movers"][0, 1]
    assert 3.0 - cart_y >= PERSON.pause_radius_m - 0.05  # it waits outside its pause radius


# A cart driving up the 2019 hallway (x = 3.5), as the 2021 config's cart does.
CART = {
    "length": 1.0,
    "width": 0.5,
    "trigger_radius": 10.0,
    "velocity": 0.6,
    "init_pose": [3.5, 1.0, 1.5708],
    "final_pose": [3.5, 6.0, 1.5708],
    "repeat": False,
}


def _hospital_with(movers: list[dict]):
    """hospital_2019 with these movers."""
    from pico_gym.world.map import map_from_dict

    data = json.loads(load_shipped("hospital_2019").source.read_text())
    data["movers"] = movers
    return map_from_dict(data, load_shipped("hospital_2019").source)


# --- the given map, doors and boxes ------------------------------------------------------------


def test_the_given_map_holds_no_closed_door_box_or_mover() -> None:
    env = hospital(n_boxes=(2, 2), n_movers=(1, 1), n_closed_doors=(1, 1))
    _, info = env.reset(seed=3)
    spec = info["task"]
    scene = env.unwrapped.scene
    assert len(scene.closed_doors) == 1 and len(scene.boxes) == 2 and len(scene.movers) == 1
    given = spec.map
    assert not given.obstacles and not given.movers
    assert len(given.doors) == 5  # the openings, all of them: nothing says which is closed
    np.testing.assert_array_equal(given.wall_segments, load_shipped("hospital_2019").wall_segments)
    assert spec.cabinet_order == tuple(spec.cabinet_order) and len(spec.cabinet_order) == 3
    assert env.unwrapped.task_spec is spec
    with pytest.raises(AttributeError):
        spec.cabinet_order = (0,)  # frozen


def _reachable(env: gym.Env, order: tuple[int, ...]) -> bool:
    """An independent check: BFS on a 0.05 m raster of everything solid, inflated by 0.1 m."""
    scene = env.unwrapped.scene
    segs = scene.static_solid
    res = 0.05
    x0, y0 = segs[:, [0, 2]].min() - 0.5, segs[:, [1, 3]].min() - 0.5
    w = int((segs[:, [0, 2]].max() + 0.5 - x0) / res)
    h = int((segs[:, [1, 3]].max() + 0.5 - y0) / res)
    xs = x0 + (np.arange(w) + 0.5) * res
    ys = y0 + (np.arange(h) + 0.5) * res
    gx, gy = np.meshgrid(xs, ys)
    px, py = gx.ravel(), gy.ravel()
    d = np.full(px.shape, np.inf)
    for x1, y1, x2, y2 in segs:
        ex, ey = x2 - x1, y2 - y1
        t = np.clip(((px - x1) * ex + (py - y1) * ey) / max(ex * ex + ey * ey, 1e-12), 0, 1)
        d = np.minimum(d, np.hypot(px - x1 - t * ex, py - y1 - t * ey))
    free = (d > 0.1).reshape(h, w)
    start = env.unwrapped.pose

    def cell(x: float, y: float) -> tuple[int, int]:
        return int((y - y0) / res), int((x - x0) / res)

    seen = np.zeros_like(free)
    queue = deque([cell(start.x, start.y)])
    seen[queue[0]] = True
    while queue:
        r, c = queue.popleft()
        for rr, cc in ((r + 1, c), (r - 1, c), (r, c + 1), (r, c - 1)):
            if 0 <= rr < h and 0 <= cc < w and free[rr, cc] and not seen[rr, cc]:
                seen[rr, cc] = True
                queue.append((rr, cc))
    world = scene.map
    return all(seen[cell(*Cabinet.of(world, i).dock_point())] for i in order)


@pytest.mark.slow
def test_closed_doors_and_boxes_never_cut_a_target_off() -> None:
    env = hospital(n_boxes=(2, 3), n_closed_doors=(1, 2), n_cabinets=4)
    closed_any = 0
    for seed in range(60):
        _, info = env.reset(seed=seed)
        scene = env.unwrapped.scene
        closed_any += bool(scene.closed_doors)
        assert 4 not in scene.closed_doors  # D5 is the start room's only door
        assert _reachable(env, info["task"].cabinet_order), seed
        for box in scene.boxes:  # boxes stay off walls, squares, the start area and doorways
            assert geometry.polygon_clearance(box, scene.map.structure_segments) > 0.0
    assert closed_any >= 50


def test_closing_a_door_that_cuts_a_target_off_is_refused_naming_it() -> None:
    env = hospital()
    with pytest.raises(ValueError, match="closing door 4 .* cuts the start area off"):
        env.reset(seed=0, options={"closed_doors": [4], "cabinet_order": [0]})
    _, info = env.reset(seed=0, options={"closed_doors": [1], "cabinet_order": [0, 1, 3]})
    assert env.unwrapped.scene.closed_doors == (1,)
    with pytest.raises(ValueError, match=r"closed_doors'\]\[0\] = 7 is out of range"):
        env.reset(seed=0, options={"closed_doors": [7]})
    with pytest.raises(ValueError, match=r"cabinet_order'\]\[1\] = 4 is out of range.*4 cabinets"):
        env.reset(seed=0, options={"cabinet_order": [0, 4]})


def test_a_count_option_takes_an_exact_number_or_a_range_and_names_a_bad_one() -> None:
    env = gym.make("PicoHospital-v0", map="hospital_2019", n_boxes=2, n_movers=1, n_closed_doors=1)
    env.reset(seed=0)
    scene = env.unwrapped.scene
    assert (len(scene.boxes), len(scene.closed_doors)) == (2, 1)
    for bad in ("2", (1, 2, 3), 2.5):
        with pytest.raises(ValueError, match=r"n_boxes must be a range \(lo, hi\) or a single integer"):
            gym.make("PicoHospital-v0", n_boxes=bad)
    with pytest.raises(ValueError, match=r"n_movers must be a range .* 0 <= lo <= hi, got \(3, 1\)"):
        gym.make("PicoHospital-v0", n_movers=(3, 1))
    # One meaning per name: the count is n_closed_doors; closed_doors names doors, in reset's options.
    with pytest.raises(TypeError, match=r"closed_doors is a reset option .* n_closed_doors=\(lo, hi\)"):
        gym.make("PicoHospital-v0", closed_doors=(1, 1))


def test_closing_a_door_lengthens_the_oracle_chain() -> None:
    env = hospital()
    lengths = {}
    for door in (None, 0, 1):
        closed = [] if door is None else [door]
        _, info = env.reset(
            seed=0, options={"closed_doors": closed, "cabinet_order": [0, 1, 3], "start_pose": (5.0, 2.5, 0.0)}
        )
        lengths[door] = info["shortest_path_length"]
    # docs/facts/hospital-facts.md 1.2: 21.2 m open, +1.1 m with D1 closed, +7.6 m with D2 (ours measures to
    # the squares' edges with the footprint's half-depth, so it is shorter, but ordered alike).
    assert 15.0 < lengths[None] < 22.0
    assert lengths[None] < lengths[0] < lengths[1]


# --- the LRF and bumps --------------------------------------------------------------------------


def test_lrf_is_exact_against_walls_cabinets_boxes_closed_doors_and_movers() -> None:
    env = hospital(n_boxes=(2, 2), n_movers=(2, 2), n_closed_doors=(1, 1))
    obs, _ = env.reset(seed=5)
    for _ in range(30):
        obs, *_ = env.step(np.array([0.0, 0.0, 0.6]))
    scene = env.unwrapped.scene
    world = scene.map
    # The reference: every part assembled from its own source, cast by brute force.
    parts = [world.structure_segments, world.cabinet_segments]
    parts += [world.door_segments[d] for d in scene.closed_doors]
    parts += [geometry.polygon_to_segments(b) for b in scene.boxes]
    from pico_gym.world.movers import box_corners

    for (x, y, yaw), rec in zip(scene.mover_poses(), scene.movers.records, strict=True):
        parts.append(geometry.polygon_to_segments(box_corners(x, y, yaw, rec.length, rec.width)))
    segs = np.vstack(parts)
    pose = env.unwrapped.pose
    angles = env.unwrapped.lrf.beam_angles
    reference = _brute_force(pose, segs, angles)
    expected = np.where(np.isfinite(reference), np.clip(reference, 0.01, 10.0), 10.0)
    np.testing.assert_allclose(obs["lrf"], expected, atol=1e-5)  # noise_m = 0
    assert np.allclose(lrf_ranges(pose, segs, angles), reference, equal_nan=True)


def _brute_force(pose: Pose, segs: np.ndarray, angles: np.ndarray) -> np.ndarray:
    out = np.full(len(angles), np.inf)
    dx, dy = np.cos(pose.theta + angles), np.sin(pose.theta + angles)
    for x1, y1, x2, y2 in segs:
        ex, ey = x2 - x1, y2 - y1
        denom = dx * ey - dy * ex
        with np.errstate(divide="ignore", invalid="ignore"):
            r = ((x1 - pose.x) * ey - (y1 - pose.y) * ex) / denom
            u = ((x1 - pose.x) * dy - (y1 - pose.y) * dx) / denom
        hit = (denom != 0) & (r > 0) & (u >= -1e-9) & (u <= 1 + 1e-9)
        out = np.where(hit & (r < out), r, out)
    out[out > 10.0] = np.inf
    return out


@pytest.mark.parametrize(
    "kind, start, action",
    [
        ("cabinet", (0.5, 3.0, UP), (0.3, 0.0, 0.0)),  # forward into cabinet 0
        ("wall", (2.1, 3.0, 0.0), (0.0, -0.3, 0.0)),  # sideways into room B's bottom wall, east of D2
        ("door", (1.25, 2.7, -UP), (0.3, 0.0, 0.0)),  # into closed door D2
    ],
)
def test_bumps_are_counted_by_kind(kind: str, start: tuple, action: tuple) -> None:
    env = hospital(collision="continue")
    env.reset(seed=0, options={"cabinet_order": [3], "closed_doors": [1], "start_pose": start})
    info = {}
    for _ in range(30):
        *_, info = env.step(np.array(action))
    assert info["bumps_by_kind"][kind] >= 1
    assert sum(info["bumps_by_kind"].values()) == info["bumps"]


def test_box_and_mover_bumps_are_counted_as_such() -> None:
    env = hospital(collision="continue", n_boxes=(1, 1))
    _, info = env.reset(seed=2, options={"cabinet_order": [3]})
    box = env.unwrapped.scene.boxes[0]
    cx, cy = box.mean(axis=0)
    # Start 0.6 m from the box's centre, facing it, if that pose is free; drive at it.
    for bearing in np.linspace(-math.pi, math.pi, 16, endpoint=False):
        x, y = cx - 0.7 * math.cos(bearing), cy - 0.7 * math.sin(bearing)
        try:
            env.reset(seed=2, options={"cabinet_order": [3], "start_pose": (x, y, float(bearing))})
        except ValueError:
            continue
        for _ in range(40):
            *_, info = env.step(np.array([0.3, 0.0, 0.0]))
        if info["bumps"]:
            break
    assert info["bumps_by_kind"]["box"] >= 1
    # A mover: a cart driving across the robot's path while the robot drives into it.
    env = gym.make("PicoHospital-v0", map=_hospital_with([CART]), collision="continue", **QUIET)
    env.reset(seed=0, options={"cabinet_order": [3], "start_pose": (3.5, 3.0, -UP)})
    for _ in range(40):
        *_, info = env.step(np.array([0.4, 0.0, 0.0]))
    assert info["bumps_by_kind"]["mover"] >= 1


# --- the generator -------------------------------------------------------------------------------


@pytest.mark.slow
def test_generated_hospitals_follow_the_rules_over_1000_seeds() -> None:
    cfg = HospitalConfig()
    for seed in range(1000):
        built = generate_hospital(np.random.default_rng(seed), cfg)
        world = built.map
        assert 3 <= len(built.rooms) <= 6, seed
        for x0, y0, x1, y1 in built.rooms:
            assert 2.0 - 1e-9 <= min(x1 - x0, y1 - y0) and max(x1 - x0, y1 - y0) <= 4.5 + 1e-9, seed
        width = min(built.hallway[0][2] - built.hallway[0][0], built.hallway[0][3] - built.hallway[0][1])
        assert 1.2 <= width <= 1.8
        for x0, y0, x1, y1 in built.doors:
            assert 0.5 - 1e-9 <= max(x1 - x0, y1 - y0) <= 1.0 + 1e-9 and min(x1 - x0, y1 - y0) == pytest.approx(0.2)
        assert 3 <= len(world.cabinets) <= 8
        walls = world.structure_segments
        for i in range(len(world.cabinets)):
            cab = Cabinet.of(world, i)
            assert cab.side_m == pytest.approx(CABINET_SIDE_M)
            assert geometry.polygon_clearance(cab.square, walls, 0.31) >= 0.3 - 1e-9
        area = world.polygon(world.start_area[0])
        assert np.ptp(area, axis=0) == pytest.approx([1.0, 1.0])
        assert geometry.polygon_clearance(area, walls) > 0.0


@pytest.mark.slow
def test_every_generated_episode_is_solvable_over_1000_seeds() -> None:
    env = gym.make("PicoHospital-v0", n_boxes=(1, 3), n_closed_doors=(0, 2), n_movers=(0, 2))
    for seed in range(1000):
        _, info = env.reset(seed=seed)
        legs = env.unwrapped.episode.extra["legs"]
        assert all(math.isfinite(leg) for leg in legs), (seed, legs)
        if seed < 40:  # and checked independently of the env's own fields
            assert _reachable(env, info["task"].cabinet_order), seed


def test_generated_episodes_are_reproducible() -> None:
    a = gym.make("PicoHospital-v0", n_movers=(1, 1))
    b = gym.make("PicoHospital-v0", n_movers=(1, 1))
    for seed in (3, 4):
        _, ia = a.reset(seed=seed)
        _, ib = b.reset(seed=seed)
        np.testing.assert_array_equal(ia["task"].map.wall_segments, ib["task"].map.wall_segments)
        np.testing.assert_array_equal(ia["movers"], ib["movers"])
        assert ia["task"].cabinet_order == ib["task"].cabinet_order


# --- bad input ------------------------------------------------------------------------------------


def _write(tmp_path, data: dict, name: str = "h.json"):
    path = tmp_path / name
    path.write_text(json.dumps(data))
    return path


def _base() -> dict:
    return json.loads(load_shipped("hospital_2019").source.read_text())


def test_bad_hospital_files_name_the_file_and_key(tmp_path) -> None:
    data = _base()
    data["cabinets"][1] = data["cabinets"][1][:2]
    with pytest.raises(MapError, match=r"h\.json: cabinets\[1\]: a closed polygon needs at least 3 segments"):
        load_map(_write(tmp_path, data))
    mover = {
        "length": 0.2,
        "width": 0.4,
        "trigger_radius": 2,
        "velocity": 0,
        "init_pose": [3, 3, 0],
        "final_pose": [3, 5, 0],
        "repeat": True,
    }
    data = _base()
    data["movers"] = [mover]
    with pytest.raises(MapError, match=r"h\.json: movers\[0\]\.velocity: must be in \(0, 2.0\]"):
        load_map(_write(tmp_path, data))
    data["movers"] = [{**mover, "velocity": 0.5, "width": -1}]
    with pytest.raises(MapError, match=r"h\.json: movers\[0\]\.width: must be in \(0, 3.0\]"):
        load_map(_write(tmp_path, data))
    data["movers"] = [{k: v for k, v in mover.items() if k != "repeat"}]
    with pytest.raises(MapError, match=r"movers\[0\]: missing key 'repeat'"):
        load_map(_write(tmp_path, data))
    data = _base()
    del data["cabinets"]
    with pytest.raises(ValueError, match="a hospital map needs 'cabinets'"):
        gym.make("PicoHospital-v0", map_path=_write(tmp_path, data))


# --- the shipped hospitals -------------------------------------------------------------------------


def test_2021_cabinets_land_on_their_image_blocks_and_face_free_floor() -> None:
    from PIL import Image

    world = load_shipped("hospital_2021")
    hm = world.heightmap
    grey = np.asarray(Image.open(world.source.parent / hm.image).convert("L"))
    rows = grey.shape[0]
    ox, oy = hm.origin
    assert len(world.cabinets) == 8

    def pixel_values(polygon: np.ndarray) -> np.ndarray:
        (x0, y0), (x1, y1) = polygon.min(axis=0), polygon.max(axis=0)
        c0, c1 = round((x0 - ox) / hm.resolution), round((x1 - ox) / hm.resolution)
        r0, r1 = rows - round((y1 - oy) / hm.resolution), rows - round((y0 - oy) / hm.resolution)
        return grey[r0:r1, c0:c1]

    robot = gym.make("PicoHospital-v0", map="hospital_2021").unwrapped.config.robot
    from pico_gym.world.hospital import square_admits_robot

    for i in range(8):
        cab = Cabinet.of(world, i)
        block = pixel_values(cab.polygon)
        # Exactly on its 16 x 16 px block (cabinet 2's block lacks one corner pixel in the image).
        assert block.shape == (16, 16) and (block >= 128).sum() <= 1, i
        assert (pixel_values(cab.square) == 255).all(), i  # the front faces free floor
        assert square_admits_robot(cab, world.solid_segments(), robot, clearance_m=0.02), i


def test_2021_heightmap_is_simplified_within_a_centimetre() -> None:
    from pico_gym.world.heightmap import heightmap_geometry, read_grey

    world = load_shipped("hospital_2021")
    hm = world.heightmap
    grey = read_grey(world.source.parent / hm.image)
    raw = heightmap_geometry(grey, hm.resolution, hm.origin).visible
    fitted = heightmap_geometry(grey, hm.resolution, hm.origin, hm.simplify_m).visible
    assert len(raw) == 1904 and len(fitted) < 0.75 * len(raw)
    corners = np.vstack([raw[:, :2], raw[:, 2:]])
    assert max(geometry.point_clearance(x, y, fitted) for x, y in corners[::3]) <= 0.01
    t = np.linspace(0, 1, 5)[:, None, None]
    along = (fitted[None, :, :2] * (1 - t) + fitted[None, :, 2:] * t).reshape(-1, 2)
    assert max(geometry.point_clearance(x, y, raw) for x, y in along[::3]) <= 0.01


def test_2021_movers_come_from_the_course_config_in_the_map_frame() -> None:
    world = load_shipped("hospital_2021")
    cart, person = world.movers
    # docs/facts/hospital-facts.md 1.6: cart x = 4.785, y 0.20 -> 2.94, yaw +90; person x = 6.725, y 6.0 <-> -0.1.
    assert cart.init_pose == pytest.approx((4.785, 0.20, UP)) and cart.final_pose == pytest.approx((4.785, 2.94, UP))
    assert person.init_pose == pytest.approx((6.725, 6.0, UP)) and person.final_pose == pytest.approx((6.725, -0.1, UP))
    assert (cart.velocity, cart.repeat, person.velocity, person.repeat) == (0.6, False, 0.5, True)
    assert cart.pause_radius_m == pytest.approx(0.86, abs=0.01) and person.pause_radius_m == pytest.approx(
        0.52, abs=0.01
    )


@pytest.mark.parametrize(
    "name",
    [
        "hospital_2019",
        "hospital_2021",
        "hospital_example",
        "hospital_testing_student_2019",
        "hospital_thick_student_2019",
    ],
)
def test_every_shipped_hospital_runs_every_cabinet_reachable(name: str) -> None:
    env = gym.make("PicoHospital-v0", map=name)
    world = load_shipped(name)
    _, info = env.reset(seed=0, options={"cabinet_order": list(range(len(world.cabinets)))})
    legs = env.unwrapped.episode.extra["legs"]
    assert all(math.isfinite(leg) for leg in legs), legs
    for _ in range(20):
        env.step(np.array([0.0, 0.0, 0.5]))


def test_back_face_culling_on_fitted_outlines_gives_the_same_scans() -> None:
    """The 2021 outline is fitted and directed (free side on the left): skipping back faces must
    not change a single range anywhere the robot can be."""
    env = gym.make("PicoHospital-v0", map="hospital_2021", **QUIET)
    env.reset(seed=0)
    scene = env.unwrapped.scene
    assert scene.static_one_sided is not None and scene.static_one_sided.sum() > 1000
    angles = env.unwrapped.lrf.beam_angles
    rng = np.random.default_rng(0)

    checked = 0
    x0, y0, x1, y1 = scene.map.bounds
    while checked < 200:
        pose = Pose(float(rng.uniform(x0, x1)), float(rng.uniform(y0, y1)), float(rng.uniform(-math.pi, math.pi)))
        if geometry.point_clearance(pose.x, pose.y, scene.static_solid) < 0.15:
            continue
        if not math.isfinite(env.unwrapped.episode.extra["fields"][0].lookup(pose.x, pose.y)):
            continue  # outside the building or inside furniture: not a pose the robot can reach
        plain = lrf_ranges(pose, scene.static_seen, angles)
        culled = lrf_ranges(pose, scene.static_seen, angles, one_sided=scene.static_one_sided)
        np.testing.assert_array_equal(plain, culled)
        checked += 1


def test_the_facing_shaping_term_pays_turning_to_face_in_the_square():
    env = gym.make("PicoHospital-v0", map="hospital_2019", n_cabinets=1, rewards={"facing": 2.0}, noise_m=0.0)
    env.reset(seed=0, options={"cabinet_order": [0], "closed_doors": []})
    target = env.unwrapped.task.next_target
    x, y = target.dock_point()
    env.reset(seed=0, options={"cabinet_order": [0], "closed_doors": [], "start_pose": (x, y, target.facing_rad - 0.6)})
    before = env.unwrapped.task._arrival_parts[2]
    _, _, _, _, info = env.step(np.array([0.0, 0.0, 1.0]))
    after = info["arrival"]["heading_error"]
    assert after < before
    assert info["reward_terms"]["facing"] == pytest.approx(2.0 * (before - after))
    # off by default: the term is there and 0
    plain = gym.make("PicoHospital-v0", map="hospital_2019", n_cabinets=1)
    plain.reset(seed=0, options={"cabinet_order": [0], "start_pose": (x, y, target.facing_rad - 0.6)})
    assert plain.step(np.array([0.0, 0.0, 1.0]))[4]["reward_terms"]["facing"] == 0.0
