"""The pico-gym command line: maps, rollout and bench-env."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from pico_gym.cli import clutter_scene, main


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


def test_rollout_writes_a_gif_and_reports(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from PIL import Image

    gif = tmp_path / "episode.gif"
    assert main(["rollout", "--map", "escape_2018", "--seed", "1", "--gif", str(gif), "--max-frames", "20"]) == 0
    out = capsys.readouterr().out
    assert "outcome:" in out and "bumps:" in out and "shortest path:" in out
    with Image.open(gif) as image:
        assert image.n_frames >= 2


def test_bench_env_prints_all_figures(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["bench-env", "--steps", "400", "--repeats", "1"]) == 0
    out = capsys.readouterr().out
    assert out.count("steps/s") >= 5 and "resets/s" in out
    for n in (20, 100, 400):
        assert f"{n:>3} segments" in out
    assert "make_vec, 2 envs, sync" in out and "make_vec, 2 envs, async" in out


def test_clutter_scene_has_the_asked_segment_count() -> None:
    for n in (20, 100, 400):
        assert clutter_scene(n).shape == (n, 4)
