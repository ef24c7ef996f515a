"""`pip install .` (not editable) ships the maps and registers the env, from any directory."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.slow
def test_regular_install_works_from_another_directory(tmp_path: Path) -> None:
    target = tmp_path / "site"
    build = subprocess.run(
        [
            sys.executable,
            "-m",
            "pip",
            "install",
            "--no-deps",
            "--no-build-isolation",
            "--quiet",
            "--target",
            str(target),
            str(ROOT),
        ],
        capture_output=True,
        text=True,
    )
    assert build.returncode == 0, build.stderr
    code = (
        "import gymnasium as gym, pico_gym; "
        f"assert pico_gym.__file__.startswith({str(target)!r}), pico_gym.__file__; "
        "env = gym.make('PicoEscape-v0', map='escape_2019'); obs, info = env.reset(seed=0); "
        "from pico_gym.world.catalog import shipped_maps; print(len(shipped_maps()), obs['lrf'].shape)"
    )
    run = subprocess.run(
        [sys.executable, "-c", code],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        env={"PYTHONPATH": str(target), "PATH": "/usr/bin:/bin"},
    )
    assert run.returncode == 0, run.stderr
    assert int(run.stdout.split()[0]) >= 6  # the shipped maps came along
    assert (target / "pico_gym" / "maps" / "escape_2018.json").is_file()
    assert (target / "pico_gym" / "maps" / "escape_room_student_2019.png").is_file()
