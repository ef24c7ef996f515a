"""Optional dependencies: checked where a user asks for the feature, with the extra to install.

>>> require("math", "plots", "a test")  # an importable module passes
"""

from __future__ import annotations

import importlib.util

from gymnasium.error import DependencyNotInstalled


def missing(module: str) -> bool:
    """True when `module` cannot be imported here (without importing it)."""
    try:
        return importlib.util.find_spec(module) is None
    except (ImportError, ValueError):
        return True


def require(module: str, extra: str, feature: str) -> None:
    """Raise gymnasium's DependencyNotInstalled, naming the extra, when `module` is missing.

    Args:
        module: the import name (e.g. "pygame").
        extra: pico-gym's extra that brings it (e.g. "render").
        feature: what the user asked for, for the message (e.g. 'render_mode="human"').
    """
    if missing(module):
        raise DependencyNotInstalled(f"{feature} needs {module}: pip install 'pico-gym[{extra}]'")
