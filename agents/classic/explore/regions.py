"""Grid geometry for the classic explore agent: distances to walls, connected parts, rooms.

Compiled with numba where the agent calls them every planning step (a 0.1 m grid of a 48 m map):
the chamfer distance transform, 8-connected labelling, region growing; and `room_depths`, which
cuts the free space into rooms at its narrow passages and counts the rooms on the way from the
start (the course's hint: the object is in the room that needs the most doors to reach).
"""

from __future__ import annotations

import math

import numpy as np

from pico_gym.jit import njit


@njit
def distance_transform(blocked: np.ndarray, res: float, cap: float) -> np.ndarray:
    """Distance from each cell centre to the nearest blocked cell (two-pass chamfer, 1 / sqrt 2)."""
    rows, cols = blocked.shape
    d = np.full((rows, cols), cap)
    diag = math.sqrt(2.0) * res
    for r in range(rows):
        for c in range(cols):
            if blocked[r, c]:
                d[r, c] = 0.0
    _chamfer_pass(d, res, diag)
    _chamfer_pass(d[::-1, ::-1], res, diag)  # the backward pass: the forward one, turned round
    return d


@njit
def _chamfer_pass(d: np.ndarray, res: float, diag: float) -> None:
    """One chamfer pass, row by row from the top left, in place."""
    rows, cols = d.shape
    for r in range(rows):
        for c in range(cols):
            v = d[r, c]
            if r > 0:
                v = min(v, d[r - 1, c] + res)
                if c > 0:
                    v = min(v, d[r - 1, c - 1] + diag)
                if c < cols - 1:
                    v = min(v, d[r - 1, c + 1] + diag)
            if c > 0:
                v = min(v, d[r, c - 1] + res)
            d[r, c] = v


@njit
def label_components(mask: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """8-connected components of `mask`: per cell its component's number (0 outside the mask,
    1, 2, ... inside) and, by number, the components' sizes (compiled: the search labels
    thousands of cells a second)."""
    rows, cols = mask.shape
    label = np.zeros((rows, cols), dtype=np.int64)
    sizes = [0]
    stack = np.empty(rows * cols, dtype=np.int64)
    for r0 in range(rows):
        for c0 in range(cols):
            if not mask[r0, c0] or label[r0, c0]:
                continue
            n = len(sizes)
            label[r0, c0] = n
            top, count = 1, 0
            stack[0] = r0 * cols + c0
            while top:
                top -= 1
                r, c = stack[top] // cols, stack[top] % cols
                count += 1
                for dr in (-1, 0, 1):
                    for dc in (-1, 0, 1):
                        rr, cc = r + dr, c + dc
                        if 0 <= rr < rows and 0 <= cc < cols and mask[rr, cc] and not label[rr, cc]:
                            label[rr, cc] = n
                            stack[top] = rr * cols + cc
                            top += 1
            sizes.append(count)
    return label, np.array(sizes)


@njit
def component_sizes(mask: np.ndarray) -> np.ndarray:
    """Per cell, the size of its 8-connected component of `mask` (0 outside the mask)."""
    label, sizes = label_components(mask)
    return sizes[label]


@njit
def grow(label: np.ndarray, space: np.ndarray, steps: int) -> np.ndarray:
    """`label`'s regions grown into the unlabelled cells of `space`, `steps` 8-neighbour steps at
    most, breadth first (each cell to the region that reaches it first)."""
    rows, cols = label.shape
    out = label.copy()
    front = np.empty(rows * cols, dtype=np.int64)
    n = 0
    for r in range(rows):
        for c in range(cols):
            if out[r, c]:
                front[n] = r * cols + c
                n += 1
    for _ in range(steps):
        grown = np.empty(rows * cols, dtype=np.int64)
        m = 0
        for i in range(n):
            r, c = front[i] // cols, front[i] % cols
            for dr in (-1, 0, 1):
                for dc in (-1, 0, 1):
                    rr, cc = r + dr, c + dc
                    if 0 <= rr < rows and 0 <= cc < cols and space[rr, cc] and not out[rr, cc]:
                        out[rr, cc] = out[r, c]
                        grown[m] = rr * cols + cc
                        m += 1
        front, n = grown, m
    return out


def room_depths(
    free: np.ndarray, walls: np.ndarray, start: tuple[int, int], res: float, join_m: float, room_m: float
) -> np.ndarray:
    """Per free cell, how many rooms one passes through to reach it from `start`, the start's own
    room or hallway not counted (0 elsewhere and in the start's part; -1 where unreachable).

    Rooms are cut from the free space at its narrow passages: the free cells farther than
    `join_m` from every wall cell, grouped (a door narrower than 2 `join_m` cuts them), make a
    room's core where somewhere in them the walls are `room_m` away (a room's middle, not a
    hallway's); each core is grown back over the free cells within `join_m` + 0.1 m of it.
    What no core reaches (a narrow hallway, a door's middle, a room's corners) joins no room:
    passing through it counts nothing. A room's depth is the fewest rooms entered on the way to
    it, itself included (the course's "doors to reach it" for rooms hanging off a hallway as a
    tree). A core within 1 m of the start is the hallway's (a wide hallway has one)."""
    clearance = distance_transform(walls, res, 2.0 * room_m)
    cores, _ = label_components(free & (clearance > join_m))
    widest = np.zeros(int(cores.max()) + 1)
    np.maximum.at(widest, cores.ravel(), clearance.ravel())
    keep = widest >= room_m
    keep[0] = False
    cores = (np.cumsum(keep) * keep)[cores]
    rooms = grow(cores, free, int(round(join_m / res)) + 1)
    gaps, _ = label_components(free & (rooms == 0))
    # Nodes: the rooms 1..R, then the gaps R+1..R+G.
    n_rooms = int(rooms.max())
    node = np.where(rooms > 0, rooms, np.where(gaps > 0, gaps + n_rooms, 0))
    n = int(node.max()) + 1
    links: list[set[int]] = [set() for _ in range(n)]
    pairs = (
        (node[1:, :], node[:-1, :]),
        (node[:, 1:], node[:, :-1]),
        (node[1:, 1:], node[:-1, :-1]),
        (node[1:, :-1], node[:-1, 1:]),
    )
    for a, b in pairs:
        touch = (a != b) & (a > 0) & (b > 0)
        for u, v in set(zip(a[touch].tolist(), b[touch].tolist(), strict=True)):
            links[u].add(v)
            links[v].add(u)
    depth = np.full(n, -1)
    first = int(node[start])
    k = int(round(1.0 / res))
    r, c = start
    near = cores[max(r - k, 0) : r + k + 1, max(c - k, 0) : c + k + 1]
    if near.any():
        first = int(np.bincount(near[near > 0]).argmax())  # the hallway's core
    if first == 0:
        return np.where(free, -1, 0)
    # 0-1 breadth first: entering a room costs one, a gap nothing.
    depth[first] = 0
    queue = [first]
    while queue:
        u = queue.pop(0)
        for v in links[u]:
            d = depth[u] + (1 if v <= n_rooms else 0)
            if depth[v] < 0 or d < depth[v]:
                depth[v] = d
                if v <= n_rooms:
                    queue.append(v)
                else:
                    queue.insert(0, v)
    out = np.where(node > 0, depth[node], 0)
    return np.where(free, out, 0)


def components(mask: np.ndarray) -> list[np.ndarray]:
    """8-connected components of a boolean mask, as arrays of (row, col)."""
    seen = np.zeros(mask.shape, dtype=bool)
    out = []
    for r0, c0 in np.argwhere(mask):
        if seen[r0, c0]:
            continue
        stack = [(int(r0), int(c0))]
        seen[r0, c0] = True
        cells = []
        while stack:
            r, c = stack.pop()
            cells.append((r, c))
            for rr, cc in (
                (r + 1, c),
                (r - 1, c),
                (r, c + 1),
                (r, c - 1),
                (r + 1, c + 1),
                (r + 1, c - 1),
                (r - 1, c + 1),
                (r - 1, c - 1),
            ):
                if 0 <= rr < mask.shape[0] and 0 <= cc < mask.shape[1] and mask[rr, cc] and not seen[rr, cc]:
                    seen[rr, cc] = True
                    stack.append((rr, cc))
        out.append(np.array(cells))
    return out


def opening(cells: np.ndarray, unknown: np.ndarray, occupied: np.ndarray, half: int = 3) -> bool:
    """Whether a small frontier opens into the unknown (a door seen at a grazing angle) rather
    than into a gap of a mapped wall: beside some unknown cell it touches, across the way into
    it, at least 5 of the 7 cells are not occupied."""
    rows, cols = unknown.shape
    for r, c in cells:
        for dr, dc in ((1, 0), (-1, 0), (0, 1), (0, -1)):
            ur, uc = r + dr, c + dc
            if not (0 <= ur < rows and 0 <= uc < cols and unknown[ur, uc]):
                continue
            clear = 0
            for k in range(-half, half + 1):
                qr, qc = ur + k * dc, uc + k * dr  # across the direction (dr, dc)
                clear += 0 <= qr < rows and 0 <= qc < cols and not occupied[qr, qc]
            if clear >= 2 * half - 1:
                return True
    return False
