"""ROS map_server maps (a metadata YAML beside a PGM or PNG), read as the course simulator reads them.

The course simulator (tue-robotics/emc_simulator, master) takes its world from ROS map_server:
`heightmap_metadata.yaml` names the image, its resolution, `origin`, `occupied_thresh`,
`free_thresh` and `negate`. map_server turns each pixel into an occupancy value
(`image_loader.cpp`):

- the pixel's colour average (with an alpha channel, trinary mode averages it in too; the other
  modes leave it out), inverted with `negate`;
- `mode: raw`: the average itself is the value; otherwise occupancy p = (255 - average) / 255,
  and p > occupied_thresh is occupied (100), p < free_thresh free (0), anything between unknown
  (-1) in trinary mode (the default) and in scale mode where alpha is 0, else 1 + 98 x the
  fraction of the way between the thresholds;
- rows flipped, so that cell (0, 0) is the lower-left pixel.

The simulator (`heightmap.cpp`, `MapLoader::mapCallback`) then draws free (0) as floor (255),
occupied (100) as a 1 m block (0) and every other value as door grey (127), finds 4-connected
blobs of grey as doors (closed, solid) and places the image with its lower-left pixel corner at
the world origin, x right and y up: it ignores `origin`.

pico-gym's defaults are the simulator's (`frame="simulator"`, `unknown="door"`); a map JSON that
references the YAML can ask for ROS's placement (`frame="ros"`: `origin`'s position and yaw
place the lower-left pixel corner) and for unknown cells as walls or floor. Where the two differ:

| | course simulator (default) | ROS map_server / nav2 (`frame="ros"`) |
|---|---|---|
| placement | lower-left pixel corner at (0, 0), `origin` ignored | `origin` (x, y, yaw): the lower-left corner's pose |
| unknown and scale values | door grey: closed doors (solid, seen) | unknown (pico-gym: `unknown=` door, wall or free) |
| occupied | a 1 m block (seen by the LRF) | occupied |

A palette image is read by its colours (map_server averages palette indices); a 16-bit PGM is
refused.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

MODES = ("trinary", "scale", "raw")
FRAMES = ("simulator", "ros")
UNKNOWN = ("door", "wall", "free")
KEYS = ("image", "resolution", "origin", "occupied_thresh", "free_thresh", "negate", "mode")
REQUIRED = ("image", "resolution", "origin", "occupied_thresh", "free_thresh", "negate")
# The course simulator's grey values after map_server (heightmap.cpp MapLoader::mapCallback).
FLOOR, BLOCK, DOOR_GREY = 255, 0, 127
MAX_YAML_BYTES = 64 * 1024


class MapServerError(ValueError):
    """A map_server metadata file or its image is unreadable or inconsistent (names file and key)."""


@dataclass(frozen=True)
class MapServerSettings:
    """A map_server map's metadata, and how pico-gym places and reads it.

    Attributes:
        image: the image path as written (relative to the YAML's folder).
        resolution: metres per pixel.
        origin: (x, y, yaw) of the lower-left pixel corner (used with `frame="ros"`).
        occupied_thresh: occupancy above which a pixel is occupied.
        free_thresh: occupancy below which a pixel is free.
        negate: white is occupied and black free (the thresholds keep their meaning).
        mode: "trinary" (default), "scale" or "raw", as map_server.
        frame: "simulator" (the course simulator: lower-left corner at (0, 0), `origin` ignored)
            or "ros" (`origin` places the map).
        unknown: what an unknown (or scale) cell becomes: "door" (the simulator's: a closed door
            blob), "wall" or "free".
    """

    image: str
    resolution: float
    origin: tuple[float, float, float]
    occupied_thresh: float
    free_thresh: float
    negate: bool
    mode: str = "trinary"
    frame: str = "simulator"
    unknown: str = "door"

    @property
    def placement(self) -> tuple[float, float, float]:
        """Where the lower-left pixel corner lands in the map frame: (x, y, yaw)."""
        return (0.0, 0.0, 0.0) if self.frame == "simulator" else self.origin


def _fail(where: Any, key: str, message: str) -> MapServerError:
    return MapServerError(f"{where}: {key}: {message}")


def _number(data: dict[str, Any], key: str, where: Any) -> float:
    value = data[key]
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise _fail(where, key, f"expected a finite number, got {value!r}")
    return float(value)


def read_metadata(path: Path, frame: str = "simulator", unknown: str = "door") -> MapServerSettings:
    """Read a map_server metadata YAML.

    Raises:
        MapServerError: naming the file and the key: a missing or unknown key, a value of the
            wrong type or out of range, YAML that is not a mapping.
    """
    import yaml

    if frame not in FRAMES:
        raise _fail(path, "frame", f"must be one of {FRAMES}, got {frame!r}")
    if unknown not in UNKNOWN:
        raise _fail(path, "unknown", f"must be one of {UNKNOWN}, got {unknown!r}")
    if path.stat().st_size > MAX_YAML_BYTES:
        raise MapServerError(f"{path}: {path.stat().st_size:,} bytes; a map_server YAML is a few lines")
    try:
        data = yaml.safe_load(path.read_text())
    except (yaml.YAMLError, UnicodeDecodeError) as error:
        raise MapServerError(f"{path}: not valid YAML ({error})") from None
    if not isinstance(data, dict):
        raise MapServerError(f"{path}: a map_server file holds a mapping of {', '.join(REQUIRED)}")
    unknown_keys = sorted(str(k) for k in data if k not in KEYS)
    if unknown_keys:
        raise _fail(path, unknown_keys[0], f"not a map_server key; the keys are {', '.join(KEYS)}")
    missing = [k for k in REQUIRED if k not in data]
    if missing:
        raise _fail(path, missing[0], "missing (map_server needs " + ", ".join(REQUIRED) + ")")
    if not isinstance(data["image"], str) or not data["image"]:
        raise _fail(path, "image", f"expected the image file's path, got {data['image']!r}")
    resolution, origin, occupied, free = _numbers(data, path)
    negate = data["negate"]
    if negate not in (0, 1) or isinstance(negate, float):
        raise _fail(path, "negate", f"expected 0 or 1, got {negate!r}")
    mode = data.get("mode", "trinary")
    if mode not in MODES:
        raise _fail(path, "mode", f"must be one of {MODES}, got {mode!r}")
    return MapServerSettings(data["image"], resolution, origin, occupied, free, bool(negate), mode, frame, unknown)


def _numbers(data: dict[str, Any], path: Path) -> tuple[float, tuple[float, float, float], float, float]:
    """resolution, origin, occupied_thresh and free_thresh, checked."""
    resolution = _number(data, "resolution", path)
    if not 0.001 <= resolution <= 10.0:
        raise _fail(path, "resolution", f"must be in [0.001, 10] m per pixel, got {resolution}")
    origin = data["origin"]
    if not (isinstance(origin, list) and len(origin) == 3):
        raise _fail(path, "origin", f"expected [x, y, yaw], got {origin!r}")
    x, y, yaw = (_number({"origin": v}, "origin", path) for v in origin)
    if max(abs(x), abs(y)) > 1e5:
        raise _fail(path, "origin", f"within 100 km of zero, got {origin!r}")
    occupied, free = _number(data, "occupied_thresh", path), _number(data, "free_thresh", path)
    if not 0.0 <= free <= occupied <= 1.0:
        raise _fail(path, "free_thresh", f"need 0 <= free_thresh <= occupied_thresh <= 1, got {free} and {occupied}")
    return resolution, (x, y, yaw), occupied, free


def read_channels(path: Path, max_pixels: int) -> tuple[np.ndarray, bool]:
    """The image's channels as map_server sees them: (rows, cols, n) uint8, and whether the last
    channel is alpha. Grey images have one channel; grey with alpha is read as RGBA (SDL's)."""
    from PIL import Image, UnidentifiedImageError

    try:
        with Image.open(path) as image:
            if image.width * image.height > max_pixels:
                raise MapServerError(f"{path}: {image.width} x {image.height} pixels; the limit is {max_pixels:,}")
            image.load()
            mode = image.mode
            if mode in ("I", "I;16", "I;16B", "F"):
                raise MapServerError(f"{path}: a 16-bit or float image ({mode}); map_server maps are 8-bit")
            if mode == "1":
                image, mode = image.convert("L"), "L"
            if mode == "P":
                mode = "RGBA" if "transparency" in image.info else "RGB"
                image = image.convert(mode)
            if mode == "LA" or mode == "PA":
                image, mode = image.convert("RGBA"), "RGBA"
            if mode not in ("L", "RGB", "RGBA"):
                image, mode = image.convert("RGB"), "RGB"
            pixels = np.asarray(image, dtype=np.uint8)
    except (UnidentifiedImageError, OSError, SyntaxError, ValueError, Image.DecompressionBombError) as error:
        raise MapServerError(f"{path}: not a readable image ({error})") from None
    if pixels.ndim == 2:
        pixels = pixels[:, :, None]
    return pixels, mode == "RGBA"


def occupancy_values(pixels: np.ndarray, has_alpha: bool, settings: MapServerSettings) -> np.ndarray:
    """map_server's occupancy values (int, -1 unknown, 0..100), in the image's row order."""
    n = pixels.shape[2]
    colours = n if (settings.mode == "trinary" or not has_alpha) else n - 1
    average = pixels[:, :, :colours].astype(np.float64).sum(axis=2) / colours
    alpha = np.ones(average.shape) if n == 1 else pixels[:, :, n - 1].astype(np.float64)
    if settings.negate:
        average = 255.0 - average
    if settings.mode == "raw":
        return average.astype(np.int64).astype(np.int8).astype(np.int64)  # (an int8 cell, as ROS stores it)
    occ = (255.0 - average) / 255.0
    values = np.full(average.shape, -1, dtype=np.int64)
    between = (occ <= settings.occupied_thresh) & (occ >= settings.free_thresh)
    if settings.mode == "scale":
        span = settings.occupied_thresh - settings.free_thresh
        ratio = (occ - settings.free_thresh) / span if span > 0 else np.zeros_like(occ)
        scaled = (1.0 + 98.0 * ratio).astype(np.int64)
        values = np.where(between & (alpha >= 1.0), scaled, values)
    values[occ > settings.occupied_thresh] = 100
    values[occ < settings.free_thresh] = 0
    return values


def course_grey(values: np.ndarray, unknown: str = "door") -> np.ndarray:
    """The grey image the course simulator builds from map_server's values: free 255, occupied 0,
    anything else door grey 127 (or, with `unknown`, a wall or floor)."""
    grey = np.full(values.shape, {"door": DOOR_GREY, "wall": BLOCK, "free": FLOOR}[unknown], dtype=np.uint8)
    grey[values == 0] = FLOOR
    grey[values == 100] = BLOCK
    return grey


def simulator_spawn(rows: int, cols: int, resolution: float) -> tuple[float, float, float]:
    """Where the course simulator puts PICO when its config gives no `initial_pose`: the map's
    centre, heading +90 deg (emc_simulator main.cpp)."""
    return (cols * resolution / 2.0, rows * resolution / 2.0, 1.57)
