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


def _csv_structured(path: Path) -> np.ndarray:
    """A CSV file with a header as a structured array (numbers as float64, integer
    columns as int64, text as str; empty cells as NaN)."""
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    if not rows:
        return np.zeros(0)
    header, body = rows[0], rows[1:]
    cols = list(zip(*body)) if body else [() for _ in header]
    dtypes, data = [], []
    for name, col in zip(header, cols):
        try:
            vals = [float(x) if x != "" else np.nan for x in col]
            if all(v == int(v) for v in vals if not np.isnan(v)) and not any(
                np.isnan(v) for v in vals
            ) and name in ("seed", "step", "state", "row", "col", "free", "visits"):
                dtypes.append((name, np.int64))
                data.append(np.array(vals, dtype=np.int64))
            else:
                dtypes.append((name, np.float64))
                data.append(np.array(vals, dtype=np.float64))
        except ValueError:
            width = max([len(x) for x in col] + [1])
            dtypes.append((name, f"U{width}"))
            data.append(np.array(col, dtype=f"U{width}"))
    out = np.zeros(len(body), dtype=dtypes)
    for (name, _), d in zip(dtypes, data):
        out[name] = d
    return out


@dataclass
class Run:
    """What a run's folder holds.

    Attributes:
        path: the folder.
        summary: ``summary.json`` as a dict (config, per-seed metrics, means with 95 %
            intervals).
        seeds: the per-seed metrics of the summary as a structured array, one row per
            seed, columns named as in ``summary.json`` (``reward/earned_per_step``, ...).
        metrics: ``metrics.csv`` (learning curves) as a structured array.
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
    rows = summary.get("seeds", [])
    names = sorted({k for r in rows for k in r})
    seeds = np.zeros(len(rows), dtype=[(n, np.float64) for n in names])
    for i, r in enumerate(rows):
        for n in names:
            v = r.get(n)
            seeds[i][n] = np.nan if v is None else v
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
    names = list(cols)
    arrays = [np.asarray(cols[n]) for n in names]
    n = len(arrays[0]) if arrays else 0
    out = np.zeros(n, dtype=[(k, a.dtype if a.dtype.kind != "U" else a.dtype) for k, a in zip(names, arrays)])
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
