"""The maps shipped with pico-gym (the repository's maps/ folder, installed as package data)."""

from __future__ import annotations

import json
from pathlib import Path

from pico_gym.world.map import IMAGE_SUFFIXES, Map, MapError, load_map


def maps_dir() -> Path:
    """The folder of the shipped maps: inside the installed package, else the source checkout's."""
    installed = Path(__file__).resolve().parents[1] / "maps"
    if installed.is_dir():
        return installed
    return Path(__file__).resolve().parents[2] / "maps"


def shipped_maps() -> dict[str, Path]:
    """Name -> file of every shipped map (JSON maps, and images not referenced by one)."""
    folder = maps_dir()
    maps = {p.stem: p for p in sorted(folder.glob("*.json"))}
    referenced = set()
    for path in maps.values():
        image = json.loads(path.read_text()).get("heightmap", {}).get("image")
        if image:
            referenced.add((folder / image).resolve())
    for p in sorted(folder.iterdir()):
        if p.suffix.lower() in IMAGE_SUFFIXES and p.stem not in maps and p.resolve() not in referenced:
            maps[p.stem] = p
    return maps


def load_shipped(name: str) -> Map:
    """Load a shipped map by name (see `pico-gym maps`).

    Raises:
        MapError: for an unknown name, listing the known ones.
    """
    maps = shipped_maps()
    if name not in maps:
        raise MapError(f"unknown map {name!r}; shipped maps: {', '.join(maps) or '(none)'}")
    return load_map(maps[name])
