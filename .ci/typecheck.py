"""mypy over pico_gym as it installs: the repository's agents/, train/ and maps/ folders are the
packages pico_gym.agents, pico_gym.train and pico_gym.maps (pyproject's package-dir), a layout
mypy cannot be told of. This lays it out in a temporary folder with links and checks it there,
with pyproject's [tool.mypy] settings.

    python .ci/typecheck.py [mypy options]
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def main() -> int:
    with tempfile.TemporaryDirectory() as tmp:
        package = Path(tmp) / "pico_gym"
        package.mkdir()
        for entry in (ROOT / "pico_gym").iterdir():
            if entry.name != "__pycache__":
                os.symlink(entry, package / entry.name)
        for name in ("agents", "train", "maps"):
            os.symlink(ROOT / name, package / name)
        command = [
            sys.executable,
            "-m",
            "mypy",
            "--config-file",
            str(ROOT / "pyproject.toml"),
            "pico_gym",
            *sys.argv[1:],
        ]
        return subprocess.call(command, cwd=tmp)


if __name__ == "__main__":
    sys.exit(main())
