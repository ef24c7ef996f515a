"""A reference scanner for benchmarks: f1tenth_gym's method (ray marching on a distance transform).

Not used by the envs. `pico-gym bench-env` times it next to pico-gym's exact LRF on the same scenes,
so the comparison with the best-known fast 2-D LiDAR simulator is measured in one run on one
machine. It follows f1tenth_gym's `laser_models.get_scan`/`trace_ray` (1080 beams over 4.7 rad, a
2000-entry sine table, eps 1e-4 m, 30 m range): rasterise the walls at 0.05 m, take the Euclidean
distance transform of the free cells, and march each beam forward by the distance to the nearest
occupied cell until it is within eps. Its cost follows the free space a beam crosses, not the
number of segments; its ranges are quantised by the raster.

`RayMarchScanner.scan` is the lean form of that loop (the map frame is the raster's, the ranges go
into a kept array); `RayMarchScanner.scan_as_shipped` does what f1tenth_gym's
`ScanSimulator2D.scan(pose, rng)` does on every call of its env: each distance lookup moves the point
into the map image's frame (translation, then rotation by the origin's yaw) and bounds-checks it, a
new array holds each scan, and Gaussian noise (std 0.01 m, one normal draw per beam) is added.
"""

from __future__ import annotations

import math

import numpy as np

from pico_gym.jit import njit
from pico_gym.types import Segments

F1TENTH_BEAMS = 1080
F1TENTH_FOV_RAD = 4.7
F1TENTH_THETA_DIS = 2000
F1TENTH_EPS = 1e-4
F1TENTH_MAX_RANGE_M = 30.0


@njit
def _rasterise(segments: Segments, x0: float, y0: float, res: float, w: int, h: int) -> np.ndarray:
    occupied = np.zeros((h, w), dtype=np.bool_)
    for k in range(segments.shape[0]):
        x1, y1, x2, y2 = segments[k, 0], segments[k, 1], segments[k, 2], segments[k, 3]
        n = int(math.hypot(x2 - x1, y2 - y1) / (0.25 * res)) + 2
        for q in range(n + 1):
            t = q / n
            c = int((x1 + t * (x2 - x1) - x0) / res)
            r = int((y1 + t * (y2 - y1) - y0) / res)
            if 0 <= r < h and 0 <= c < w:
                occupied[r, c] = True
    return occupied


@njit
def _edt_1d(f: np.ndarray, d: np.ndarray, v: np.ndarray, z: np.ndarray) -> None:
    """Felzenszwalb-Huttenlocher: d[q] = min_p (q - p)^2 + f[p]."""
    n = f.shape[0]
    k = 0
    v[0] = 0
    z[0] = -1e20
    z[1] = 1e20
    for q in range(1, n):
        s = ((f[q] + q * q) - (f[v[k]] + v[k] * v[k])) / (2.0 * q - 2.0 * v[k])
        while s <= z[k]:
            k -= 1
            s = ((f[q] + q * q) - (f[v[k]] + v[k] * v[k])) / (2.0 * q - 2.0 * v[k])
        k += 1
        v[k] = q
        z[k] = s
        z[k + 1] = 1e20
    k = 0
    for q in range(n):
        while z[k + 1] < q:
            k += 1
        d[q] = (q - v[k]) * (q - v[k]) + f[v[k]]


@njit
def _edt(occupied: np.ndarray, res: float) -> np.ndarray:
    """Distance (metres) from every cell to the nearest occupied cell."""
    h, w = occupied.shape
    big = 1e20
    g = np.empty((h, w))
    n = max(h, w)
    f = np.empty(n)
    d = np.empty(n)
    v = np.empty(n, dtype=np.int64)
    z = np.empty(n + 1)
    for c in range(w):
        for r in range(h):
            f[r] = 0.0 if occupied[r, c] else big
        _edt_1d(f[:h], d[:h], v, z)
        for r in range(h):
            g[r, c] = d[r]
    for r in range(h):
        for c in range(w):
            f[c] = g[r, c]
        _edt_1d(f[:w], d[:w], v, z)
        for c in range(w):
            g[r, c] = math.sqrt(d[c]) * res
    return g


@njit
def _distance(x: float, y: float, x0: float, y0: float, res: float, dt: np.ndarray) -> float:
    c = int((x - x0) / res) if x >= x0 else -1
    r = int((y - y0) / res) if y >= y0 else -1
    if r < 0 or c < 0 or r >= dt.shape[0] or c >= dt.shape[1]:
        return 0.0  # off the map: the march stops
    return dt[r, c]


@njit
def _scan(
    x: float,
    y: float,
    theta: float,
    n_beams: int,
    fov: float,
    sines: np.ndarray,
    cosines: np.ndarray,
    x0: float,
    y0: float,
    res: float,
    dt: np.ndarray,
    eps: float,
    max_range: float,
    out: np.ndarray,
) -> None:
    theta_dis = sines.shape[0]
    increment = theta_dis * (fov / (n_beams - 1)) / (2.0 * math.pi)
    index = np.fmod(theta_dis * (theta - fov / 2.0) / (2.0 * math.pi), theta_dis)
    while index < 0.0:
        index += theta_dis
    for i in range(n_beams):
        s = sines[int(index)]
        c = cosines[int(index)]
        px, py = x, y
        step = _distance(px, py, x0, y0, res, dt)
        total = step
        while step > eps and total <= max_range:
            px += step * c
            py += step * s
            step = _distance(px, py, x0, y0, res, dt)
            total += step
        out[i] = min(total, max_range)
        index += increment
        while index >= theta_dis:
            index -= theta_dis


@njit
def _image_cell(
    x: float, y: float, x0: float, y0: float, cos0: float, sin0: float, height: int, width: int, res: float
) -> tuple[int, int]:
    """f1tenth_gym's lookup cell: (row, col) of a map point in the image, (-1, -1) off it."""
    xt = x - x0
    yt = y - y0
    xr = xt * cos0 + yt * sin0
    yr = -xt * sin0 + yt * cos0
    if xr < 0.0 or xr >= width * res or yr < 0.0 or yr >= height * res:
        return -1, -1
    return int(yr / res), int(xr / res)


@njit
def _scan_as_shipped(
    pose: np.ndarray,
    n_beams: int,
    fov: float,
    sines: np.ndarray,
    cosines: np.ndarray,
    x0: float,
    y0: float,
    yaw0: float,
    res: float,
    dt: np.ndarray,
    eps: float,
    max_range: float,
) -> np.ndarray:
    """`_scan` as f1tenth_gym's `get_scan` runs it: the lookup through `_image_cell`, a new array."""
    theta_dis = sines.shape[0]
    increment = theta_dis * (fov / (n_beams - 1)) / (2.0 * math.pi)
    cos0 = math.cos(yaw0)
    sin0 = math.sin(yaw0)
    height, width = dt.shape
    out = np.empty(n_beams)
    index = np.fmod(theta_dis * (pose[2] - fov / 2.0) / (2.0 * math.pi), theta_dis)
    while index < 0.0:
        index += theta_dis
    for i in range(n_beams):
        s = sines[int(index)]
        c = cosines[int(index)]
        px = pose[0]
        py = pose[1]
        r, col = _image_cell(px, py, x0, y0, cos0, sin0, height, width, res)
        step = dt[r, col]  # (-1, -1) off the image reads its last cell, as in f1tenth_gym
        total = step
        while step > eps and total <= max_range:
            px += step * c
            py += step * s
            r, col = _image_cell(px, py, x0, y0, cos0, sin0, height, width, res)
            step = dt[r, col]
            total += step
        out[i] = min(total, max_range)
        index += increment
        while index >= theta_dis:
            index -= theta_dis
    return out


class RayMarchScanner:
    """f1tenth_gym's scan on a raster of `segments` (resolution `res` metres)."""

    def __init__(
        self, segments: Segments, res: float = 0.05, n_beams: int = F1TENTH_BEAMS, fov: float = F1TENTH_FOV_RAD
    ) -> None:
        segs = np.asarray(segments, dtype=np.float64).reshape(-1, 4)
        lo = segs.reshape(-1, 2).min(axis=0) - 1.0
        hi = segs.reshape(-1, 2).max(axis=0) + 1.0
        self.origin = (float(lo[0]), float(lo[1]))
        self.res = res
        w, h = (int(v) + 1 for v in (hi - lo) / res)
        self.dt = _edt(_rasterise(segs, self.origin[0], self.origin[1], res, w, h), res)
        angles = np.linspace(0.0, 2.0 * math.pi, F1TENTH_THETA_DIS)
        self.sines, self.cosines = np.sin(angles), np.cos(angles)
        self.n_beams, self.fov = n_beams, fov
        self.out = np.empty(n_beams)

    def scan(self, x: float, y: float, theta: float) -> np.ndarray:
        _scan(
            x, y, theta, self.n_beams, self.fov, self.sines, self.cosines, self.origin[0], self.origin[1],
            self.res, self.dt, F1TENTH_EPS, F1TENTH_MAX_RANGE_M, self.out,
        )  # fmt: skip
        return self.out

    def scan_as_shipped(self, pose: np.ndarray, rng: np.random.Generator, std_dev: float = 0.01) -> np.ndarray:
        """A new noisy scan from pose (x, y, theta) as an array, as f1tenth_gym's env takes one."""
        scan = _scan_as_shipped(
            pose, self.n_beams, self.fov, self.sines, self.cosines, self.origin[0], self.origin[1], 0.0,
            self.res, self.dt, F1TENTH_EPS, F1TENTH_MAX_RANGE_M,
        )  # fmt: skip
        scan += rng.normal(0.0, std_dev, size=self.n_beams)
        return scan
