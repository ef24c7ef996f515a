"""The "Training with other libraries" recipes (docs/recipes/) run as written, for a few thousand
steps: plain stable-baselines3, CleanRL's env stack on gymnasium 1.x, rl-zoo3 with its YAML."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

RECIPES = Path(__file__).resolve().parents[1] / "docs" / "recipes"


def _run(args: list[str], cwd: Path) -> str:
    run = subprocess.run([sys.executable, *args], capture_output=True, text=True, cwd=cwd, timeout=600)
    assert run.returncode == 0, run.stderr[-3000:]
    return run.stdout


@pytest.mark.slow
def test_sb3_recipe_trains_and_evaluates(tmp_path: Path) -> None:
    pytest.importorskip("stable_baselines3")
    out = _run([str(RECIPES / "sb3_ppo.py"), "--timesteps", "2048", "--out", str(tmp_path / "m")], tmp_path)
    assert "trained 2048 steps; evaluation episode:" in out
    assert (tmp_path / "m.zip").is_file()


@pytest.mark.slow
def test_cleanrl_env_stack_runs_on_gymnasium_1(tmp_path: Path) -> None:
    out = _run([str(RECIPES / "cleanrl_env.py"), "--steps", "3000"], tmp_path)
    assert "ran 3000 steps" in out and "observation (2, 67)" in out
    assert "episodic_return=" in out  # finished episodes were read from gymnasium 1.x's final_info


@pytest.mark.slow
def test_rl_zoo3_recipe_trains(tmp_path: Path) -> None:
    pytest.importorskip("rl_zoo3")
    args = ["-m", "rl_zoo3.train", "--algo", "ppo", "--env", "PicoEscape-v0", "--gym-packages", "pico_gym"]
    args += ["-conf", str(RECIPES / "rl_zoo3_ppo.yml"), "-n", "4096", "--seed", "0", "--eval-freq", "-1"]
    out = _run([*args, "-f", str(tmp_path / "logs")], tmp_path)
    assert "total_timesteps" in out
    assert list((tmp_path / "logs" / "ppo").glob("PicoEscape-v0_*/PicoEscape-v0.zip"))
