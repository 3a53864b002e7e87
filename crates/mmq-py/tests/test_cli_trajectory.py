"""The same seed and the same actions give the same trajectory from Python and from the
CLI: the CLI's MCAP recording, replayed action by action through mmq/Grid-v0."""

import gymnasium as gym
import numpy as np
import pytest

import mmq
from conftest import cli


@pytest.mark.parametrize("env_id,env_flag,steps", [("mmq/Grid-v0", "grid", 1500),
                                                   ("mmq/Robot-v0", "robot", 60)])
def test_python_replays_the_cli_recording(tmp_path, env_id, env_flag, steps):
    seed, delay = 4, "poisson:6"
    cli("run", "--world", "worlds/paper-5x5.toml", "--env", env_flag, "--learner", "q",
        "--delay", delay, "--steps", str(steps), "--seeds", "1", "--seed", str(seed),
        "--no-baseline", "--record", "-q", "--out", str(tmp_path))
    rec = mmq.read_recording(tmp_path / f"trajectory-seed{seed}.mcap")
    assert rec.complete and len(rec.decisions) == steps
    env = gym.make(env_id, world="paper-5x5", delay=delay, max_episode_steps=10**9)
    s, _ = env.reset(seed=seed)
    assert s == rec.decisions["state"][0]
    emitted, delivered = {}, {}
    for row in rec.decisions:
        assert s == row["state"]
        s, r, _, _, info = env.step(int(row["action"]))
        assert s == row["next_state"] and info["event"] == row["event"]
        if info["delay_steps"] >= 0:
            emitted[info["t"]] = (info["emitted"], info["delay_steps"])
        if r != 0.0:
            delivered[info["t"]] = r
    assert emitted == {int(e["t"]): (float(e["value"]), int(e["delay"])) for e in rec.emitted}
    cli_delivered = {int(d["t"]): float(d["sum"]) for d in rec.delivered if d["sum"] != 0.0}
    assert delivered == cli_delivered
    assert len(emitted) > 3
    if env_flag == "robot":
        assert len(rec.poses) > steps
        assert np.all(np.diff(rec.poses["time_ns"].astype(np.int64)) >= 0)
