"""Maps: course JSON and heightmaps load, files round-trip, bad files raise a clear MapError."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest
from helpers import REFERENCE_MAPS, box_room

from pico_gym.world.catalog import load_shipped, shipped_maps
from pico_gym.world.heightmap import heightmap_geometry
from pico_gym.world.map import MapError, load_map, maps_equal, save_map


def test_course_json_maps_load_as_they_are() -> None:
    hospital = load_map(REFERENCE_MAPS / "hospital_2019.json")
    assert len(hospital.cabinets) == 4 and len(hospital.start_area) == 1
    assert hospital.wall_segments.shape == (40 + 16, 4)  # 40 walls + 4 cabinets of 4 sides
    assert {"nodes", "nodelinks"} <= set(hospital.extra)  # a team's extra keys are kept
    example = load_map(REFERENCE_MAPS / "json_example_map.json")
    assert len(example.cabinets) == 2
    front = example.cabinets[0][0]  # the first segment is the front
    assert example.points[front].tolist() == [[1.4, 2.4], [1.4, 2.8]]


@pytest.mark.parametrize(
    "name", ["maze_2017.pgm", "escape_room_student_2019.png", "er_large2_student_2019.png", "hospital_2021.png"]
)
def test_course_heightmaps_load(name: str) -> None:
    world = load_map(REFERENCE_MAPS / name)
    assert len(world.wall_segments) > 10
    x0, y0, x1, y1 = world.bounds
    assert 2.0 < x1 - x0 < 20.0 and 2.0 < y1 - y0 < 20.0


def test_heightmap_doors_and_low_pixels() -> None:
    world = load_map(REFERENCE_MAPS / "doors_example_2015.png")
    assert len(world.door_segments) == 4
    # er_large2 has near-white pixels (248-254): a user who drew the map means them as floor
    # (occupancy below ROS map_server's free threshold 0.1), so nothing invisible is left to bump.
    large2 = load_map(REFERENCE_MAPS / "er_large2_student_2019.png")
    assert len(large2.low_segments) == 0
    # Between the free threshold and the laser plane a pixel is solid but unseen, as in the course.
    grey = np.full((20, 20), 255, dtype=np.uint8)
    grey[5, 5] = 229  # occupancy 0.102: solid, 0.10 m tall: under the laser
    grey[10, 10] = 230  # occupancy 0.098: floor
    grey[15, 15] = 20  # 0.92 m tall: seen (51-204 would be door grey)
    geo = heightmap_geometry(grey, 0.025, None)
    assert len(geo.low) == 4 and len(geo.visible) == 4


def test_heightmap_placements() -> None:
    grey = np.full((40, 20), 255, dtype=np.uint8)  # 40 rows, 20 columns
    grey[0, 0] = 0  # top-left pixel
    course = heightmap_geometry(grey, 0.025, None).visible
    # Course placement: centre at the origin, x up the image, y to the left.
    assert course[:, [0, 2]].max() == pytest.approx(20 * 0.025)
    assert course[:, [1, 3]].max() == pytest.approx(10 * 0.025)
    ros = heightmap_geometry(grey, 0.025, (1.0, 2.0)).visible
    # ROS placement: origin = lower-left corner, x right, y up: the pixel sits at the top left.
    assert ros[:, [0, 2]].min() == pytest.approx(1.0)
    assert ros[:, [1, 3]].max() == pytest.approx(2.0 + 40 * 0.025)
    assert len(course) == 4 and len(ros) == 4  # one pixel: four edges


def test_pixel_edges_merge_into_long_segments() -> None:
    grey = np.full((50, 50), 255, dtype=np.uint8)
    grey[10:13, 5:45] = 0  # a 40 x 3 pixel wall
    segs = heightmap_geometry(grey).visible
    assert len(segs) == 4
    lengths = sorted(np.hypot(segs[:, 2] - segs[:, 0], segs[:, 3] - segs[:, 1]))
    assert lengths == pytest.approx([0.075, 0.075, 1.0, 1.0])


def test_rgba_transparent_pixels_are_free(tmp_path: Path) -> None:
    from PIL import Image

    rgba = np.zeros((20, 20, 4), dtype=np.uint8)  # black but fully transparent
    rgba[5, 5] = (0, 0, 0, 255)  # one opaque black pixel
    Image.fromarray(rgba).save(tmp_path / "a.png")  # (20, 20, 4) uint8 is RGBA
    assert len(load_map(tmp_path / "a.png").wall_segments) == 4


@pytest.mark.parametrize("name", sorted(shipped_maps()))
def test_round_trip_of_every_shipped_map(name: str, tmp_path: Path) -> None:
    world = load_shipped(name)
    out = tmp_path / "sub" / f"{name}.json"
    out.parent.mkdir()
    save_map(world, out)
    # (the copy references the shipped images where they are: outside its folder, so allowed here)
    again = load_map(out, allow_outside=True)
    assert maps_equal(world, again)
    save_map(again, out.parent / "twice.json")
    assert (out.parent / "twice.json").read_text() == out.read_text()


def test_shipped_escape_maps_have_finish_lines() -> None:
    escape = [n for n in shipped_maps() if n.startswith("escape_") and n != "escape_room_student_2019"]
    assert len(escape) >= 4
    assert all(load_shipped(n).finish is not None for n in escape)
    assert "hospital_2019" in shipped_maps()


BAD_MAPS = [
    ({"points": [[0, 0], [1, 0]]}, "missing key 'walls'"),
    ({"walls": [[0, 1]]}, "missing key 'points'"),
    ({"points": [[0, 0], [1, 0]], "walls": [[0, 5]]}, r"walls\[0\]: point index 5 out of range"),
    ({"points": [[0, 0], {"x": 1}], "walls": []}, r"points\[1\]: a point needs keys 'x' and 'y'"),
    (
        {"points": [[0, 0], [1, 0], [1, 1]], "walls": [], "cabinets": [[[0, 1], [1, 2]]]},
        r"cabinets\[0\]: .*closed polygon",
    ),
    (
        {"points": [[0, 0], [1, 0], [1, 1], [0, 1]], "walls": [], "start_area": [[[0, 1], [1, 2], [2, 3]]]},
        r"start_area\[0\]: .*closed polygon",
    ),
    ({**box_room(), "start_pose": {"x": 1.95, "y": 0.0, "theta": 0.0}}, "start_pose: the robot at .* overlaps a wall"),
    ({**box_room(), "start_pose": {"x": 0.0, "y": 0.0}}, "start_pose: missing key 'theta'"),
    ({**box_room(), "finish": [[0, 0]]}, r"finish: expected \[\[x1, y1\], \[x2, y2\]\]"),
    ({"heightmap": {"image": "nope.png"}}, "heightmap.image: file not found"),
    ({**box_room(), "version": 7}, "version: unsupported version 7"),
    ([1, 2, 3], "must hold a JSON object"),
]


@pytest.mark.parametrize("data,message", BAD_MAPS)
def test_bad_maps_raise_map_error_naming_file_and_key(data: object, message: str, write_json) -> None:
    path = write_json(data, "bad.json")
    with pytest.raises(MapError, match=message) as error:
        load_map(path)
    assert str(path) in str(error.value)


def test_files_that_are_not_json_or_not_images(tmp_path: Path) -> None:
    text = tmp_path / "broken.json"
    text.write_text("{ not json")
    with pytest.raises(MapError, match=r"broken.json: not valid JSON"):
        load_map(text)
    fake = tmp_path / "fake.png"
    fake.write_text("this is not an image")
    with pytest.raises(MapError, match=r"fake.png.*not a readable image"):
        load_map(fake)
    with pytest.raises(MapError, match="no such map file"):
        load_map(tmp_path / "missing.json")
    with pytest.raises(MapError, match="unknown map 'nowhere'; shipped maps:"):
        load_shipped("nowhere")


def test_heightmap_path_is_relative_to_the_map_file(tmp_path: Path) -> None:
    shutil.copy(REFERENCE_MAPS / "maze_2017.pgm", tmp_path / "maze.pgm")
    (tmp_path / "m.json").write_text(json.dumps({"heightmap": {"image": "maze.pgm", "origin": [0, 0]}}))
    world = load_map(tmp_path / "m.json")
    assert world.bounds[0] >= -1e-9 and world.bounds[1] >= -1e-9
