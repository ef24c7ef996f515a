"""Python's own float functions, compiled, to the last bit.

The step's compiled parts must compute what the Python code they replace computed, bit for bit,
so that an episode is the same whichever path steps it (one env, a vector env). Most of `math`
compiles to the same C library calls in numba, and numba's float `%` is Python's. Two do not:
`math.hypot` is CPython's own correctly rounded vector norm (the C library's `hypot` differs in
the last bit for about one argument pair in 200), and numba has no `math.remainder`. Both are
here, ported from CPython's mathmodule.c (`vector_norm` for two coordinates, `m_remainder`), and
tested equal to Python's on random arguments.
"""

from __future__ import annotations

import math

import numpy as np

from pico_gym.jit import njit

TWO_PI = 2.0 * math.pi
_DBL_MIN = 2.2250738585072014e-308
_VELTKAMP = 134217729.0  # 2 ** 27 + 1


@njit
def _square(x: float) -> tuple[float, float]:
    """x * x as an unevaluated sum hi + lo, exactly (Dekker's product with Veltkamp's split)."""
    t = x * _VELTKAMP
    hi = t - (t - x)
    lo = x - hi
    p = hi * hi
    q = hi * lo + lo * hi
    z = p + q
    return z, p - z + q + lo * lo


@njit
def _norm(x0: float, x1: float, largest: float) -> float:
    """CPython's `vector_norm` for two finite non-negative coordinates, largest > 0."""
    _, e = math.frexp(largest)
    if e < -1023:  # subnormal: scale up to normals first, as CPython does
        return _DBL_MIN * _norm(x0 / _DBL_MIN, x1 / _DBL_MIN, largest / _DBL_MIN)
    scale = math.ldexp(1.0, -e)
    csum = 1.0
    frac1 = 0.0
    frac2 = 0.0
    for v in (x0, x1):
        hi, lo = _square(v * scale)
        total = csum + hi
        frac2 += hi - (total - csum)
        csum = total
        frac1 += lo
    h = math.sqrt(csum - 1.0 + (frac1 + frac2))
    hi, lo = _square(h)
    hi, lo = -hi, -lo
    total = csum + hi
    frac2 += hi - (total - csum)
    csum = total
    frac1 += lo
    h += (csum - 1.0 + (frac1 + frac2)) / (2.0 * h)
    return h / scale


@njit
def hypot(x: float, y: float) -> float:
    """`math.hypot(x, y)`, bit for bit."""
    x0, x1 = abs(x), abs(y)
    largest = max(x0, x1)
    if math.isinf(x0) or math.isinf(x1):
        return math.inf
    if math.isnan(x0) or math.isnan(x1):
        return math.nan
    if largest == 0.0:
        return largest
    return _norm(x0, x1, largest)


@njit
def remainder(x: float, y: float) -> float:
    """`math.remainder(x, y)` (IEEE 754 remainder) for finite x and finite non-zero y."""
    ax, ay = abs(x), abs(y)
    m = np.fmod(ax, ay)
    c = ay - m
    if m < c:
        r = m
    elif m > c:
        r = -c
    else:  # half way: towards the even multiple
        r = m - 2.0 * np.fmod(0.5 * (ax - m), ay)
    return math.copysign(1.0, x) * r


@njit
def wrap_angle(angle: float) -> float:
    """`pico_gym.world.geometry.wrap_angle`, compiled: the angle in [-pi, pi)."""
    return (angle + math.pi) % TWO_PI - math.pi
