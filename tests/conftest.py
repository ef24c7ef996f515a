"""Shared fixtures: headless pygame, small maps built in code."""

from __future__ import annotations

import json
import os
from pathlib import Path

import pytest

os.environ.setdefault("SDL_VIDEODRIVER", "dummy")
os.environ.setdefault("SDL_AUDIODRIVER", "dummy")


@pytest.fixture
def write_json(tmp_path: Path):
    """Write a dict as a JSON map file and return its path."""

    def write(data: object, name: str = "map.json") -> Path:
        path = tmp_path / name
        path.write_text(json.dumps(data))
        return path

    return write
