"""A missing optional dependency is reported where the feature is asked for, naming the extra."""

from __future__ import annotations

import subprocess
import sys
import textwrap

import pytest

BLOCK = """
import sys
class Block:
    def find_spec(self, name, path=None, target=None):
        if name.split(".")[0] in {blocked!r}:
            raise ImportError(f"{{name}} is blocked in this test")
sys.meta_path.insert(0, Block())
"""


def _run(blocked: set[str], body: str, tmp_path) -> subprocess.CompletedProcess:
    code = BLOCK.format(blocked=blocked) + textwrap.dedent(body)
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=tmp_path, timeout=300)


def test_render_mode_without_pygame_fails_at_make_naming_the_extra(tmp_path) -> None:
    run = _run(
        {"pygame"},
        """
        import gymnasium as gym, pico_gym
        from gymnasium.error import DependencyNotInstalled
        gym.make("PicoEscape-v0")  # no render mode: fine
        try:
            gym.make("PicoHospital-v0", render_mode="rgb_array")
        except DependencyNotInstalled as error:
            print(error)
        """,
        tmp_path,
    )
    assert run.returncode == 0, run.stderr
    assert "needs pygame: pip install 'pico-gym[render]'" in run.stdout


def test_compare_without_matplotlib_stops_before_the_first_episode(tmp_path) -> None:
    run = _run(
        {"matplotlib"},
        """
        import sys
        from pico_gym.cli import main
        sys.exit(main(["compare", "--episodes", "50", "--quiet", "--out", "out"]))
        """,
        tmp_path,
    )
    assert run.returncode == 2, run.stderr
    assert "needs matplotlib: pip install 'pico-gym[plots]'" in run.stderr and "Traceback" not in run.stderr
    assert not (tmp_path / "out" / "results.md").exists()


def test_a_zip_policy_without_torch_names_the_train_extra(tmp_path) -> None:
    from pico_gym.agents.ppo import SHIPPED_MODEL

    if not SHIPPED_MODEL.is_file():
        pytest.skip("the SB3 zip is in the repository, not in a wheel")
    copy = tmp_path / "policy.zip"
    copy.write_bytes(SHIPPED_MODEL.read_bytes())
    (tmp_path / "policy.json").write_text(SHIPPED_MODEL.with_suffix(".json").read_text())
    run = _run(
        {"torch", "stable_baselines3"},
        f"""
        import sys
        from pico_gym.cli import main
        sys.exit(main(["run", "--agent", "ppo", "--policy", {str(copy)!r}]))
        """,
        tmp_path,
    )
    assert run.returncode == 2, run.stderr
    assert "pico-gym[train]" in run.stderr and "Traceback" not in run.stderr


def test_video_without_moviepy_names_the_extra(tmp_path) -> None:
    run = _run(
        {"moviepy"},
        """
        import sys
        from pico_gym.cli import main
        sys.exit(main(["run", "--agent", "random", "--video", "x.mp4"]))
        """,
        tmp_path,
    )
    assert run.returncode == 2
    assert "--video needs moviepy: pip install 'pico-gym[video]'" in run.stderr
