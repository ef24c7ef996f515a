"""JSON files read as untrusted input: numbers that fit a float, bounded size and depth.

`json.loads` turns a 400-digit integer into a Python int that later overflows a float deep
inside the code, reads `NaN` and `Infinity` as numbers, and fails a deeply nested file with a
RecursionError. `read_json` refuses each of them at the file, naming it.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

MAX_JSON_BYTES = 16 * 1024 * 1024
MAX_DEPTH = 64
MAX_INT_DIGITS = 15  # integers beyond this are not exact as floats (2^53)


class JsonError(ValueError):
    """A JSON file that cannot be read safely; the message names the file and what is wrong."""


def _int(text: str) -> int:
    if len(text.lstrip("-")) > MAX_INT_DIGITS:
        raise JsonError(f"the integer {text[:12]}... ({len(text)} digits) is too large for a map or config")
    return int(text)


def _float(text: str) -> float:
    value = float(text)
    if not math.isfinite(value):
        raise JsonError(f"the number {text[:24]} is too large (it is not a finite float)")
    return value


def _constant(name: str) -> float:
    raise JsonError(f"{name} is not a number a map or config may hold")


def _depth(value: Any, limit: int) -> int:
    """The nesting depth of parsed JSON, stopping past `limit`."""
    stack, deepest = [(value, 1)], 0
    while stack:
        item, depth = stack.pop()
        deepest = max(deepest, depth)
        if deepest > limit:
            return deepest
        if isinstance(item, dict):
            stack.extend((v, depth + 1) for v in item.values())
        elif isinstance(item, list):
            stack.extend((v, depth + 1) for v in item)
    return deepest


def loads(text: str, where: Any) -> Any:
    """Parse JSON text read from `where`.

    Raises:
        JsonError: naming `where`: not JSON (with the line and column), a number that does not fit
            a float, NaN or Infinity, nesting deeper than `MAX_DEPTH`.
    """
    try:
        data = json.loads(text, parse_int=_int, parse_float=_float, parse_constant=_constant)
    except JsonError as error:
        raise JsonError(f"{where}: {error}") from None
    except RecursionError:
        raise JsonError(f"{where}: nested deeper than {MAX_DEPTH} levels") from None
    except json.JSONDecodeError as error:
        raise JsonError(f"{where}: not valid JSON: {error.msg} at line {error.lineno}, column {error.colno}") from None
    if _depth(data, MAX_DEPTH) > MAX_DEPTH:
        raise JsonError(f"{where}: nested deeper than {MAX_DEPTH} levels")
    return data


def read_json(path: str | Path) -> Any:
    """Read a JSON file as untrusted input (see `loads`); also refused: a folder, a missing file,
    more than `MAX_JSON_BYTES`, bytes that are not text."""
    path = Path(path)
    if path.is_dir():
        raise JsonError(f"{path}: a folder, not a JSON file")
    if not path.is_file():
        raise JsonError(f"{path}: no such file")
    size = path.stat().st_size
    if size > MAX_JSON_BYTES:
        raise JsonError(f"{path}: {size:,} bytes; the limit is {MAX_JSON_BYTES:,}")
    try:
        text = path.read_text()
    except UnicodeDecodeError as error:
        raise JsonError(f"{path}: not a JSON file (not text: {error.reason})") from None
    return loads(text, path)
