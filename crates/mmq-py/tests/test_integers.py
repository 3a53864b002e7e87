"""Exact integers: seeds (up to 2**64 - 1) and integer columns read back as integers,
never through floats; a run whose seed failed to write a file reads back with that seed
marked failed."""

import subprocess

import numpy as np
import pytest

import mmq
from conftest import ROOT, cli, mmq_bin

BIG = [2**53 + 1, 2**64 - 1]


@pytest.mark.parametrize("seed", BIG)
def test_read_run_keeps_the_seed_exact(tmp_path, seed):
    out = tmp_path / "run"
    cli("run", "--world", "paper-3x3", "--steps", "2000", "--seeds", "1", "--seed", str(seed),
        "--window", "500", "-q", "--out", str(out))
    run = mmq.read_run(out)
    assert run.summary["seeds"][0]["seed"] == seed  # json keeps it
    assert run.seeds.dtype["seed"] == np.uint64 and int(run.seeds["seed"][0]) == seed
    assert run.seeds["complete"][0] and not run.seeds["failed"][0] and run.seeds["error"][0] == ""
    assert run.seeds.dtype["steps"] == np.int64 and run.seeds["steps"][0] == 2000
    assert run.seeds.dtype["reward/earned_total"] == np.float64
    assert run.metrics.dtype["seed"] == np.uint64 and run.metrics.dtype["step"] == np.int64
    assert [int(s) for s in run.metrics["seed"]] == [seed] * 4
    assert list(run.metrics["step"]) == [500, 1000, 1500, 2000]
    assert run.policy.dtype["seed"] == np.uint64 and {int(s) for s in run.policy["seed"]} == {seed}
    for name in ("state", "row", "col", "free", "visits"):
        assert run.policy.dtype[name] == np.int64, name
    assert f"q_seed{seed}" in run.tables
    pd = pytest.importorskip("pandas")
    assert isinstance(run.seeds_df, pd.DataFrame)
    assert int(run.seeds_df["seed"].iloc[0]) == seed and int(run.metrics_df["seed"].iloc[0]) == seed


def test_read_recording_keeps_integers_exact(tmp_path):
    seed = 2**64 - 1
    out = tmp_path / "rec"
    cli("run", "--world", "paper-3x3", "--steps", "300", "--seeds", "1", "--seed", str(seed),
        "--delay", "poisson:3", "--record", "-q", "--out", str(out))
    rec = mmq.read_recording(out / f"trajectory-seed{seed}.mcap")
    assert rec.complete and len(rec.decisions) == 300
    assert rec.metadata["run"]["seed"] == str(seed)
    assert rec.decisions.dtype["t"] == np.uint64 and rec.decisions.dtype["time_ns"] == np.uint64
    assert list(rec.decisions["t"]) == list(range(300))
    for name in ("state", "action", "model", "next_state"):
        assert rec.decisions.dtype[name] == np.int64, name
    assert rec.emitted.dtype["id"] == np.uint64 and rec.emitted.dtype["delay"] == np.int64
    assert rec.decisions["event"].dtype.kind == "U" and rec.emitted["cause"].dtype.kind == "U"
    assert rec.deliveries.dtype["t_emit"] == np.uint64 and len(rec.deliveries) > 0


def test_a_run_with_a_failed_seed_reads_with_that_seed_marked(tmp_path):
    """A recording cut by a file-size limit: the run fails (exit 1) but writes its
    summary, whose seed says why; read_run reads it."""
    out = tmp_path / "run"
    script = "trap '' XFSZ; ulimit -f 400; exec \"$0\" \"$@\""
    r = subprocess.run(
        ["sh", "-c", script, mmq_bin(), "run", "--world", "paper-9x9", "--steps", "30000",
         "--seed", str(2**64 - 1), "--record", "-q", "--out", str(out)],
        cwd=ROOT, capture_output=True, text=True,
    )
    assert r.returncode == 1, r.stderr
    assert "trajectory-seed" in r.stderr
    run = mmq.read_run(out)
    assert run.summary["complete"] is False
    assert len(run.seeds) == 1 and int(run.seeds["seed"][0]) == 2**64 - 1
    assert run.seeds["failed"][0] and not run.seeds["complete"][0]
    assert f"trajectory-seed{2**64 - 1}.mcap" in run.seeds["error"][0]
    assert 0 < run.seeds["steps"][0] <= 30000  # the seed stops where its recording failed
