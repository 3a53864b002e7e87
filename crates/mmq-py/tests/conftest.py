"""Shared helpers: the repository root and the `mmq` CLI binary (`MMQ_BIN`, else the
release build, else the debug build that `cargo test` leaves)."""

import os
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[3]


def mmq_bin() -> str:
    b = os.environ.get("MMQ_BIN")
    if b:
        return b
    for p in (ROOT / "target/release/mmq", ROOT / "target/debug/mmq"):
        if p.is_file():
            return str(p)
    pytest.fail("the mmq CLI is not built: run `cargo build --release` or set MMQ_BIN")


def cli(*args: str) -> subprocess.CompletedProcess:
    r = subprocess.run([mmq_bin(), *args], cwd=ROOT, capture_output=True, text=True)
    assert r.returncode == 0, f"mmq {' '.join(args)} failed:\n{r.stderr}"
    return r
