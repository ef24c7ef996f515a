"""`pip install .` (not editable) ships the maps and registers the env, from any directory; it adds
one import name, `pico_gym`, and running it writes nothing into the installed package."""

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
        "from pico_gym.agents import make_agent; agent = make_agent('classic', env); agent.reset(obs, info); "
        "agent.act(obs); "
        "from pico_gym.world.catalog import shipped_maps; print(len(shipped_maps()), obs['lrf'].shape)"
    )
    run = subprocess.run(
        [sys.executable, "-c", code],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        env={"PYTHONPATH": str(target), "PATH": "/usr/bin:/bin", "NUMBA_CACHE_DIR": str(tmp_path / "numba")},
    )
    assert run.returncode == 0, run.stderr
    assert int(run.stdout.split()[0]) >= 6  # the shipped maps came along
    assert (target / "pico_gym" / "maps" / "escape_2018.json").is_file()
    assert (target / "pico_gym" / "maps" / "escape_room_student_2019.png").is_file()
    # One namespace: nothing but pico_gym (and its metadata) at the top level.
    top_level = {p.name for p in target.iterdir() if not p.name.endswith(".dist-info") and p.name != "bin"}
    assert top_level == {"pico_gym"}, top_level
    assert (target / "pico_gym" / "agents" / "classic" / "agent.py").is_file()
    assert (target / "pico_gym" / "train" / "configs" / "ppo_escape.yaml").is_file()
    # numba's cache went to the user cache directory, not into the package (an uninstall would
    # leave such files behind as namespace-package folders that shadow a later install).
    assert not list(target.rglob("*.nbi")) and not list(target.rglob("*.nbc"))
    assert list((tmp_path / "numba").rglob("*.nbi"))


def test_the_kernel_cache_is_keyed_by_every_module_of_the_package() -> None:
    # numba keys a cached kernel by its own bytecode only: a kernel calling another module's kernel
    # (the vector batch calls the env's `_drive`) would run stale machine code after that module
    # changed. pico_gym's cache adds a digest of every module to the key.
    from pico_gym.jit import njit, package_digest

    @njit
    def twice(x: float) -> float:
        return 2.0 * x

    assert twice(1.5) == 3.0
    cache = twice._cache
    if not hasattr(cache, "_index_key"):
        pytest.skip("no writable user cache directory: the kernels compile in memory only")
    sig = twice.signatures[0]
    key = cache._index_key(sig, twice.targetctx.codegen())
    assert key[-1] == package_digest() and len(package_digest()) == 64
