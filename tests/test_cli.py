"""The pico-gym command line: maps, bench-env, --version, --help defaults and one-line errors."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from pico_gym.bench import clutter_scene, free_poses
from pico_gym.cli import main


def test_maps_lists_the_shipped_maps(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["maps"]) == 0
    out = capsys.readouterr().out
    for name in ("escape_2018", "escape_2019", "escape_2020_corner", "hospital_2019"):
        assert name in out


def test_maps_draws_a_png(tmp_path: Path) -> None:
    from PIL import Image

    out = tmp_path / "m.png"
    assert main(["maps", "escape_2020_corner", "--png", str(out)]) == 0
    image = np.asarray(Image.open(out).convert("L"))
    assert image.shape == (640, 640) and (image < 100).any()


def test_unknown_map_is_a_clear_error(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["maps", "atlantis"]) == 2
    assert "unknown map 'atlantis'" in capsys.readouterr().err


def test_version_and_defaults_in_help(capsys: pytest.CaptureFixture[str]) -> None:
    import pico_gym

    with pytest.raises(SystemExit):
        main(["--version"])
    assert capsys.readouterr().out.strip() == f"pico-gym {pico_gym.__version__}"
    with pytest.raises(SystemExit):
        main(["bench", "--help"])
    assert "(default: 100)" in " ".join(capsys.readouterr().out.split())


@pytest.mark.parametrize(
    "args, message",
    [
        (["--set", "noise_mm=0.02"], "--set noise_mm: no such env option (did you mean noise_m"),
        (["--set", "noise_m=abc"], "--set noise_m=abc: expected a float"),
        (["--set", "collision=3"], "--set collision=3: expected a str"),
        (["--set", "noise_m"], "--set takes KEY=VALUE"),
    ],
)
def test_bad_set_is_a_one_line_error(args: list[str], message: str, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["bench", "--episodes", "1", "--quiet", *args]) == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err and len(err.strip().splitlines()) == 1


def test_bench_json_into_a_missing_folder_fails_before_any_episode(tmp_path: Path, capsys) -> None:
    assert main(["bench", "--episodes", "500", "--quiet", "--json", str(tmp_path / "no" / "out.json")]) == 2
    assert "does not exist" in capsys.readouterr().err


def test_render_human_without_a_display_says_so(monkeypatch, capsys: pytest.CaptureFixture[str]) -> None:
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    assert main(["run", "--agent", "random", "--render", "human"]) == 2
    assert "needs a display" in capsys.readouterr().err


@pytest.mark.slow
def test_bench_env_prints_all_figures(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["bench-env", "--steps", "400", "--repeats", "1"]) == 0
    out = capsys.readouterr().out
    assert out.count("steps/s") >= 5 and "resets/s" in out
    for n in (20, 100, 400):
        assert f"{n:>3} segments" in out
    for row in ("16 envs, vector_entry_point", "16 envs, sync", "2 envs, vector_entry_point", "2 envs, async"):
        assert f"make_vec, {row}" in out
    moving = out.split("the sensor at 64 free poses in turn")[1]
    assert all(f"{n:>4} segments" in moving for n in (20, 100, 400, 1000, 2000))
    noisy = out.split("as each env scans on every step")[1].split("the sensor at 64 free poses")[0]
    assert all(f"{n:>4} segments" in noisy for n in (20, 100, 400, 1000, 2000)) and "hospital_2021" in noisy


def test_clutter_scene_has_the_asked_segment_count() -> None:
    for n in (20, 100, 400):
        assert clutter_scene(n).shape == (n, 4)


def test_free_poses_keep_their_clearance_and_repeat_with_the_seed() -> None:
    scene = clutter_scene(1000, seed=2)
    poses = free_poses(scene, 32, seed=5)
    assert len(poses) == 32 and poses == free_poses(scene, 32, seed=5)
    a, e = scene[:, :2], scene[:, 2:] - scene[:, :2]
    for x, y, theta in poses:
        t = np.clip(((np.array([x, y]) - a) * e).sum(axis=1) / (e * e).sum(axis=1), 0.0, 1.0)
        assert np.hypot(*(a + t[:, None] * e - [x, y]).T).min() >= 0.3
        assert -4.9 <= x <= 4.9 and -4.9 <= y <= 4.9 and -np.pi <= theta <= np.pi


def test_bench_walls_counts_overlaps_of_the_true_footprint(capsys: pytest.CaptureFixture[str]) -> None:
    main(["bench-walls", "--steps", "600"])
    out = capsys.readouterr().out
    assert "adversarial driving (PicoEscape-v0):" in out and "true footprint overlapping something solid:" in out


def test_the_f1tenth_reference_as_shipped_is_its_lean_loop_plus_noise() -> None:
    """The bench's two f1tenth references march the same raster: the as-written one (its lookup
    through the image frame, a new array per scan) gives the lean loop's ranges, plus its noise."""
    from pico_gym.sensors.raymarch import RayMarchScanner

    marcher = RayMarchScanner(clutter_scene(400, seed=4))
    for x, y, theta in free_poses(clutter_scene(400, seed=4), 8, seed=1):
        lean = marcher.scan(x, y, theta).copy()
        pose = np.array([x, y, theta])
        first = marcher.scan_as_shipped(pose, np.random.default_rng(3), std_dev=0.0)
        assert np.array_equal(first, lean)
        assert marcher.scan_as_shipped(pose, np.random.default_rng(3), std_dev=0.0) is not first
        noisy = marcher.scan_as_shipped(pose, np.random.default_rng(3))
        assert np.array_equal(noisy, lean + np.random.default_rng(3).normal(0.0, 0.01, lean.size))
