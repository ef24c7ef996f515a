"""Typed configuration plumbing: keyword overrides into nested frozen dataclasses.

`gym.make("PicoEscape-v0", n_beams=64, collision="continue")` reaches the field `n_beams` of the
LRF config and `collision` of the task config: a keyword names a field of the env config or of any
config nested in it, as long as the name is unique. A nested config can also be replaced whole
(`lrf=LrfConfig(...)`) or updated from a dict (`rewards={"progress": 2.0}`).
"""

from __future__ import annotations

import dataclasses
from typing import Any, TypeVar

C = TypeVar("C")


def _nested(config: Any) -> list[tuple[str, Any]]:
    return [
        (f.name, getattr(config, f.name))
        for f in dataclasses.fields(config)
        if dataclasses.is_dataclass(getattr(config, f.name))
    ]


def _find(config: Any, key: str, path: tuple[str, ...] = ()) -> list[tuple[str, ...]]:
    hits = [path + (key,)] if key in {f.name for f in dataclasses.fields(config)} else []
    for name, sub in _nested(config):
        hits += _find(sub, key, path + (name,))
    return hits


def all_options(config: Any, path: tuple[str, ...] = ()) -> list[str]:
    """Dotted names of every field reachable from a config."""
    names = []
    for f in dataclasses.fields(config):
        names.append(".".join(path + (f.name,)))
        value = getattr(config, f.name)
        if dataclasses.is_dataclass(value):
            names += all_options(value, path + (f.name,))
    return names


def with_overrides(config: C, **overrides: Any) -> C:
    """A copy of a (nested) frozen dataclass config with fields replaced by keyword.

    Every config is rebuilt once with all of its changes, so its checks see the final values
    (e.g. a higher speed together with the shorter physics sub-step that keeps walls solid).

    Raises:
        TypeError: for a keyword that names no field, or more than one.
    """
    paths: list[tuple[tuple[str, ...], Any]] = []
    for key, value in overrides.items():
        hits = _find(config, key)
        if not hits:
            raise TypeError(f"unknown option {key!r}; options are: {', '.join(all_options(config))}")
        top_level = [h for h in hits if len(h) == 1]
        if len(hits) > 1 and not top_level:
            raise TypeError(f"option {key!r} is ambiguous: {', '.join('.'.join(h) for h in hits)}")
        paths.append((top_level[0] if top_level else hits[0], value))
    return _apply(config, paths)


def _apply(config: C, paths: list[tuple[tuple[str, ...], Any]]) -> C:
    """`config` with each (path, value) set, each nested config rebuilt once."""
    changes: dict[str, Any] = {}
    nested: dict[str, list[tuple[tuple[str, ...], Any]]] = {}
    for path, value in paths:
        head = path[0]
        if len(path) > 1:
            nested.setdefault(head, []).append((path[1:], value))
            continue
        current = changes.get(head, getattr(config, head))
        if dataclasses.is_dataclass(current) and not isinstance(current, type):
            if isinstance(value, dict):
                value = with_overrides(current, **value)
            elif not isinstance(value, type(current)):
                kind = type(current).__name__
                raise TypeError(f"{head} must be a {kind} or a dict of its fields, got {value!r:.60}")
        changes[head] = value
    for head, items in nested.items():
        changes[head] = _apply(changes.get(head, getattr(config, head)), items)
    return dataclasses.replace(config, **changes)  # type: ignore[type-var]  # (C is a dataclass)
