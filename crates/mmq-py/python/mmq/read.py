"""Readers: a run's output folder (``mmq run --out DIR``, ``mmq.run(out=DIR)``) and an
MCAP recording (``--record``), as NumPy arrays (and pandas DataFrames when pandas is
installed)."""

from __future__ import annotations

import csv
import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from mmq import _mmq


def _frame(arr: np.ndarray):
    """A pandas DataFrame of a structured array, or None without pandas."""
    try:
        import pandas as pd
    except ImportError:
        return None
    return pd.DataFrame.from_records(arr)


# Integer columns of the run's CSV files: read with int(), never through a float.
# `seed` is uint64 (master seeds span 0..2**64), the others int64.
_CSV_INTEGERS = ("seed", "step", "state", "row", "col", "free", "visits")

# Per-seed metrics of summary.json that count something: int64 in `Run.seeds`, −1 for a
# seed that has none (e.g. `delay/delivered` when nothing was delivered).
_COUNT_METRICS = ("steps", "delay/delivered")
_COUNT_PREFIXES = ("events/",)


def _column(name: str, col: tuple[str, ...]) -> np.ndarray:
    """One CSV column: integers for the integer columns, else numbers as float64 (empty
    cells as NaN), else text."""
    if name in _CSV_INTEGERS:
        try:
            ints = [int(x) for x in col]
            return np.array(ints, dtype=np.uint64 if name == "seed" else np.int64)
        except (ValueError, OverflowError):
            pass
    try:
        return np.array([float(x) if x != "" else np.nan for x in col], dtype=np.float64)
    except ValueError:
        width = max([len(x) for x in col] + [1])
        return np.array(col, dtype=f"U{width}")


def _csv_structured(path: Path) -> np.ndarray:
    """A CSV file with a header as a structured array (see :func:`_column`)."""
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    if not rows:
        return np.zeros(0)
    header, body = rows[0], rows[1:]
    cols = list(zip(*body)) if body else [() for _ in header]
    data = [_column(name, col) for name, col in zip(header, cols)]
    out = np.zeros(len(body), dtype=[(n, d.dtype) for n, d in zip(header, data)])
    for n, d in zip(header, data):
        out[n] = d
    return out


def _is_count(name: str) -> bool:
    return name in _COUNT_METRICS or name.startswith(_COUNT_PREFIXES)


def _seed_rows(rows: list[dict[str, Any]]) -> np.ndarray:
    """The per-seed entries of summary.json as a structured array: ``seed`` (uint64),
    ``complete`` and ``failed`` (bool), ``error`` (text, empty when none), the counts
    (int64, −1 when absent) and every other metric (float64, NaN when absent)."""
    metrics = sorted({k for r in rows for k in r} - {"seed", "complete", "error"})
    width = max([len(r.get("error") or "") for r in rows] + [1])
    dtype = [("seed", np.uint64), ("complete", bool), ("failed", bool), ("error", f"U{width}")]
    dtype += [(n, np.int64 if _is_count(n) else np.float64) for n in metrics]
    out = np.zeros(len(rows), dtype=dtype)
    for i, r in enumerate(rows):
        out["seed"][i] = int(r["seed"])
        out["complete"][i] = bool(r.get("complete", True))
        out["failed"][i] = r.get("error") is not None
        out["error"][i] = r.get("error") or ""
        for n in metrics:
            v = r.get(n)
            if _is_count(n):
                out[n][i] = -1 if v is None else int(v)
            else:
                out[n][i] = np.nan if v is None else float(v)
    return out


@dataclass
class Run:
    """What a run's folder holds.

    Attributes:
        path: the folder.
        summary: ``summary.json`` as a dict (config, per-seed metrics, means with 95 %
            intervals).
        seeds: the per-seed entries of the summary as a structured array, one row per
            seed: ``seed`` (uint64, exact), ``complete``, ``failed`` (an output of the
            seed could not be written) and ``error`` (why; empty when none), then the
            metrics named as in ``summary.json`` (``reward/earned_per_step``, ...):
            counts (``steps``, ``events/*``, ``delay/delivered``) as int64 with −1 where
            a seed has none, the rest as float64 with NaN where a seed has none.
        metrics: ``metrics.csv`` (learning curves) as a structured array: ``seed``
            uint64, ``step`` int64, the rest float64.
        policy: ``policy.csv`` (per-state visits, values, greedy actions) or ``None``.
        tables: the ``.npy`` tables by file stem (``q_seed0``, ...).
        config: ``config.toml`` as text.
        metrics_df, seeds_df: the same as pandas DataFrames when pandas is installed,
            else ``None``.
    """

    path: Path
    summary: dict[str, Any]
    seeds: np.ndarray
    metrics: np.ndarray
    policy: np.ndarray | None
    tables: dict[str, np.ndarray] = field(default_factory=dict)
    config: str = ""
    metrics_df: Any = None
    seeds_df: Any = None


def read_run(path: str | Path) -> Run:
    """Reads the output folder of ``mmq run`` or :func:`mmq.run`."""
    p = Path(path)
    sp = p / "summary.json"
    if not sp.is_file():
        raise _mmq.ConfigError(
            f"path: {p} has no summary.json; pass the --out folder of a finished `mmq run`"
        )
    summary = json.loads(sp.read_text())
    seeds = _seed_rows(summary.get("seeds", []))
    metrics = _csv_structured(p / "metrics.csv") if (p / "metrics.csv").is_file() else np.zeros(0)
    policy = _csv_structured(p / "policy.csv") if (p / "policy.csv").is_file() else None
    tables = {f.stem: np.load(f) for f in sorted(p.glob("*.npy"))}
    config = (p / "config.toml").read_text() if (p / "config.toml").is_file() else ""
    return Run(
        path=p,
        summary=summary,
        seeds=seeds,
        metrics=metrics,
        policy=policy,
        tables=tables,
        config=config,
        metrics_df=_frame(metrics) if metrics.dtype.names else None,
        seeds_df=_frame(seeds) if seeds.dtype.names else None,
    )


def _structured(cols: dict[str, Any]) -> np.ndarray:
    """Columns (NumPy arrays of their own dtype from the reader, or lists of text) as one
    structured array; integer columns keep their dtype (uint64 times and steps)."""
    names = list(cols)
    arrays = [
        c if isinstance(c, np.ndarray) else np.array(c, dtype=f"U{max([len(x) for x in c] + [1])}")
        for c in (cols[n] for n in names)
    ]
    n = len(arrays[0]) if arrays else 0
    out = np.zeros(n, dtype=[(k, a.dtype) for k, a in zip(names, arrays)])
    for k, a in zip(names, arrays):
        out[k] = a
    return out


@dataclass
class Recording:
    """What an MCAP recording holds, as structured arrays.

    Attributes:
        decisions: one row per decision step: ``time_ns`` (simulated), ``t``, ``state``,
            ``action``, ``model`` (−1: none), ``explored``, ``next_state``, ``event``.
        emitted: one row per non-zero reward: ``id``, ``t``, ``value``, ``delay``
            (steps), ``due``, ``cause``.
        deliveries: one row per emission delivered: ``t`` (delivery step), ``id``,
            ``t_emit``, ``delay`` (steps), ``value``.
        delivered: one row per delivery: ``t``, ``sum``.
        poses: the robot's poses: ``time_ns``, ``x``, ``y`` (metres), ``theta`` (rad).
        metadata: the log's metadata records (``run``: seed, learner, config, ...).
        complete: the file was read to its end; ``stop`` says where and why not.
    """

    decisions: np.ndarray
    emitted: np.ndarray
    deliveries: np.ndarray
    delivered: np.ndarray
    poses: np.ndarray
    metadata: dict[str, dict[str, str]]
    complete: bool
    stop: str | None


def read_recording(path: str | Path) -> Recording:
    """Reads an MCAP recording (``mmq run --record``) with mmq's own reader (a truncated
    file gives what was readable, with ``complete`` False)."""
    c = _mmq.read_recording_columns(str(path))
    return Recording(
        decisions=_structured(c["decisions"]),
        emitted=_structured(c["emitted"]),
        deliveries=_structured(c["deliveries"]),
        delivered=_structured(c["delivered"]),
        poses=_structured(c["poses"]),
        metadata={k: dict(v) for k, v in c["metadata"].items()},
        complete=c["complete"],
        stop=c["stop"],
    )
