"""Checks for typed configs: every setting validated where it enters, with the option's name.

>>> number("LrfConfig.noise_m", 0.01, lo=0.0)
0.01
>>> number("LrfConfig.noise_m", float("nan"), lo=0.0)
Traceback (most recent call last):
...
ValueError: LrfConfig.noise_m must be a finite number, got nan
"""

from __future__ import annotations

import math
from typing import Any


def number(
    name: str,
    value: Any,
    lo: float | None = None,
    hi: float | None = None,
    *,
    lo_open: bool = False,
    integer: bool = False,
    unit: str = "",
) -> float:
    """`value` as a number, or ValueError naming `name` and the bound it breaks.

    Args:
        name: the option, as a user would look it up (e.g. "PhysicsConfig.contact_skin_m").
        value: what was given.
        lo, hi: inclusive bounds (`lo_open`: lo itself is refused).
        integer: a whole number is required.
        unit: appended to the bounds in the message.
    """
    kind = "an integer" if integer else "a finite number"
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ValueError(f"{name} must be {kind}, got {value!r}")
    if integer and not float(value).is_integer():
        raise ValueError(f"{name} must be {kind}, got {value!r}")
    if not math.isfinite(value):
        raise ValueError(f"{name} must be {kind}, got {value!r}")
    if lo is not None and (value < lo or (lo_open and value == lo)):
        raise ValueError(f"{name} must be {'>' if lo_open else '>='} {lo}{unit}, got {value!r}")
    if hi is not None and value > hi:
        raise ValueError(f"{name} must be <= {hi}{unit}, got {value!r}")
    return value


def span(name: str, value: Any, lo: float | None = None, hi: float | None = None, *, integer: bool = False) -> tuple:
    """A (low, high) range with low <= high, both within [lo, hi]."""
    if not (isinstance(value, (tuple, list)) and len(value) == 2):
        raise ValueError(f"{name} must be a range (low, high), got {value!r}")
    a = number(f"{name}[0]", value[0], lo, hi, integer=integer)
    b = number(f"{name}[1]", value[1], lo, hi, integer=integer)
    if a > b:
        raise ValueError(f"{name} must have low <= high, got {value!r}")
    return (a, b)


def flag(name: str, value: Any) -> bool:
    if not isinstance(value, bool):
        raise ValueError(f"{name} must be True or False, got {value!r}")
    return value


def index_list(name: str, value: Any, n: int, what: str, where: Any = "") -> list[int]:
    """A list of distinct indices into `n` things (`what`), or ValueError naming `name`: a list,
    tuple or 1-D array of ints (no bools, strings, floats or dicts), at most `n` long (checked
    before any element is read), each in 0..n-1, none twice."""
    import numpy as np

    at = f" in {where}" if where else ""
    if isinstance(value, np.ndarray):
        if value.ndim != 1 or value.dtype.kind not in "iu":
            raise ValueError(f"{name} must be a list of {what} indices (integers), got an array of {value.dtype}")
        value = value.tolist()
    if not isinstance(value, (list, tuple)):
        raise ValueError(f"{name} must be a list of {what} indices, got {type(value).__name__} {value!r:.60}")
    if len(value) > n:
        raise ValueError(f"{name} lists {len(value):,} {what}s; there are {n}{at} (0..{n - 1}), each at most once")
    out: list[int] = []
    for k, i in enumerate(value):
        if isinstance(i, bool) or not isinstance(i, (int, np.integer)):
            raise ValueError(f"{name}[{k}] must be an integer {what} index, got {i!r:.40}")
        if not 0 <= i < n:
            raise ValueError(f"{name}[{k}] = {i} is out of range: there are {n} {what}s{at} (0..{n - 1})")
        if int(i) in out:
            raise ValueError(f"{name}[{k}] = {i} is listed twice: each {what} at most once")
        out.append(int(i))
    return out
