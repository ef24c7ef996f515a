"""A run's records across sessions (a resume starts a new session).

SB3's CSV logger rewrites tb/progress.csv when a session starts, and its clock starts again. So
each finished or killed session's file is kept as tb/progress.<k>.csv; the run's progress.csv is
the sessions joined: a session's rows past the step the next one resumed from are dropped (they
were redone), and its `time/time_elapsed` counts from the start of the run.
"""

from __future__ import annotations

import csv
import math
import os
import re
from pathlib import Path
from typing import Any

# SB3's CSV logger rewrites tb/progress.csv when a session starts, and its clock starts again. So
# each finished or killed session's file is kept as tb/progress.<k>.csv; the run's progress.csv is
# the sessions joined: a session's rows past the step the next one resumed from are dropped (they
# were redone), and its `time/time_elapsed` counts from the start of the run.
_ELAPSED = "time/time_elapsed"
_STEPS = "time/total_timesteps"


def _csv_rows(path: Path) -> tuple[list[str], list[dict[str, str]]]:
    try:
        with path.open(newline="") as f:
            reader = csv.DictReader(f)
            return list(reader.fieldnames or []), list(reader)
    except (OSError, csv.Error):
        return [], []


def _write_csv(path: Path, fields: list[str], rows: list[dict[str, Any]]) -> None:
    tmp = path.with_name(path.name + ".tmp")
    with tmp.open("w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=fields, extrasaction="ignore")
        writer.writeheader()
        writer.writerows(rows)
    os.replace(tmp, path)


def _number_or(row: dict[str, str], key: str, default: float) -> float:
    try:
        return float(row.get(key) or default)
    except ValueError:
        return default


def _session_files(run_dir: Path) -> list[Path]:
    files = [
        (int(m.group(1)), f)
        for f in (run_dir / "tb").glob("progress.*.csv")
        if (m := re.fullmatch(r"progress\.(\d+)\.csv", f.name))
    ]
    return [f for _, f in sorted(files)]


def start_session(run_dir: Path, resumed_at: int | None) -> float:
    """Keep the previous session's progress file, drop eval rows that the resume will redo, and
    return the wall clock the run has spent so far [s] (0 for a new run)."""
    tb = run_dir / "tb"
    current = tb / "progress.csv"
    if resumed_at is None:
        for f in _session_files(run_dir):
            f.unlink()
        current.unlink(missing_ok=True)
        return 0.0
    if current.exists():
        os.replace(current, tb / f"progress.{len(_session_files(run_dir))}.csv")
    evals = run_dir / "eval.csv"
    last_eval_s = 0.0
    if evals.exists():
        fields, rows = _csv_rows(evals)
        kept = [r for r in rows if _number_or(r, "timesteps", 0) <= resumed_at]
        if len(kept) != len(rows):
            _write_csv(evals, fields, kept)
        last_eval_s = max((_number_or(r, "wall_clock_s", 0.0) for r in kept), default=0.0)
    # SB3 logs time_elapsed in whole seconds, so the sessions' sum can fall short of the clock
    # an evaluation already wrote down; the run's clock never goes back.
    elapsed = sum(_number_or((_csv_rows(f)[1] or [{}])[-1], _ELAPSED, 0.0) for f in _session_files(run_dir))
    return max(elapsed, last_eval_s)


def join_progress(run_dir: Path) -> None:
    """Write the run's progress.csv: every session's rows, joined (see above)."""
    sessions = [_csv_rows(f) for f in [*_session_files(run_dir), run_dir / "tb" / "progress.csv"]]
    sessions = [(fields, rows) for fields, rows in sessions if rows]
    if not sessions:
        return
    fields: list[str] = []
    for names, _ in sessions:
        fields += [n for n in names if n not in fields]
    joined: list[dict[str, Any]] = []
    offset = 0.0
    for k, (_, rows) in enumerate(sessions):
        resumed_at = (
            min((_number_or(r, _STEPS, math.inf) for r in sessions[k + 1][1]), default=math.inf)
            if k + 1 < len(sessions)
            else math.inf
        )
        for row in rows:
            if _number_or(row, _STEPS, 0.0) < resumed_at:
                if _ELAPSED in row and row[_ELAPSED] not in ("", None):
                    row = {**row, _ELAPSED: f"{offset + _number_or(row, _ELAPSED, 0.0):g}"}
                joined.append(row)
        offset += _number_or(rows[-1], _ELAPSED, 0.0)
    _write_csv(run_dir / "progress.csv", fields, joined)
