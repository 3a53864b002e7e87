"""Learning from Python: a plain-Python tabular Q-learner reaches the optimum, MMQ from
Python gives the CLI's Q-table bit for bit, and mmq.run / read_run."""

import gymnasium as gym
import numpy as np
import pytest

import mmq
from conftest import cli


def greedy_score(env, policy, steps=1000):
    env.reset(seed=0)
    total = 0.0
    s = env.unwrapped._state
    for _ in range(steps):
        s, r, _, _, info = env.step(policy(s))
        total += info["emitted"]
    return total / steps


def test_plain_python_q_learning_learns_the_undelayed_9x9():
    env = gym.make("mmq/Grid-v0", world="paper-9x9", delay="none", max_episode_steps=10**9)
    n, na = env.observation_space.n, env.action_space.n
    q = np.full((n, na), 20.0)
    rng = np.random.default_rng(0)
    alpha, gamma, eps = 0.1, 0.9, 0.1
    s, _ = env.reset(seed=0)
    for _ in range(120_000):
        row = q[s]
        a = int(rng.integers(na)) if rng.random() < eps else int(rng.choice(np.flatnonzero(row == row.max())))
        s2, r, _, _, _ = env.step(a)
        q[s, a] += alpha * (r + gamma * q[s2].max() - q[s, a])
        s = s2
    greedy = gym.make("mmq/Grid-v0", world="paper-9x9", delay="none", start="respawn",
                      max_episode_steps=10**9)
    score = greedy_score(greedy, lambda st: int(np.argmax(q[st])))
    opt = mmq.optimum("paper-9x9")["gain"]
    assert score >= 0.9 * opt, (score, opt)


SETTINGS = dict(alpha=0.1, gamma=0.9, epsilon=0.05, q0=20.0, max_delay=12)


def python_mmq(world, delay, steps, seed):
    env = gym.make("mmq/Grid-v0", world=world, delay=delay, max_episode_steps=10**9)
    learner = mmq.Learner("mmq", env.observation_space.n, env.action_space.n, seed=seed,
                          **SETTINGS)
    s, _ = env.reset(seed=seed)
    for _ in range(steps):
        a = learner.act(s)
        s2, r, _, _, _ = env.step(a)
        learner.observe(s, a, r, s2)
        s = s2
    return learner


def test_mmq_from_python_equals_the_cli(tmp_path):
    steps, seed = 4000, 3
    out = tmp_path / "cli"
    cli("run", "--world", "worlds/paper-5x5.toml", "--learner", "mmq", "--delay", "poisson:4",
        "--steps", str(steps), "--seeds", "1", "--seed", str(seed), "--no-baseline",
        "--alpha", "0.1", "--gamma", "0.9", "--epsilon", "0.05", "--q0", "20",
        "--max-delay", "12", "-q", "--out", str(out))
    expected = np.load(out / f"q_seed{seed}.npy")
    learner = python_mmq("paper-5x5", "poisson:4", steps, seed)
    assert learner.q.shape == expected.shape == (25, 13, 4)
    assert np.array_equal(learner.q, expected)
    # Not trivially equal: the table moved away from q0.
    assert (expected != 20.0).sum() > 100
    # mmq.run is the CLI's runner.
    summary = mmq.run("paper-5x5", learner="mmq", delay="poisson:4", steps=steps, seed=seed,
                      baseline=False, out=str(tmp_path / "py"), **SETTINGS)
    assert summary["complete"] is True
    run = mmq.read_run(tmp_path / "py")
    assert np.array_equal(run.tables[f"q_seed{seed}"], expected)
    cli_run = mmq.read_run(out)
    assert run.summary["seeds"] == cli_run.summary["seeds"] or all(
        {k: v for k, v in a.items() if "time" not in k and "per_s" not in k}
        == {k: v for k, v in b.items() if "time" not in k and "per_s" not in k}
        for a, b in zip(run.summary["seeds"], cli_run.summary["seeds"])
    )
    assert run.metrics["step"][-1] == steps and len(run.seeds) == 1


def test_learner_api():
    lr = mmq.Learner("q", 9, 4, seed=0, epsilon=0.0, q0=0.0, alpha=0.5)
    lr.observe(0, 1, 10.0, 1)
    assert lr.q[0, 1] == pytest.approx(5.0)  # 0 + 0.5 (10 + 0.9·0 − 0)
    assert lr.greedy(0) == 1 and lr.act(0) == 1
    assert list(lr.action_values(0)) == [0.0, 5.0, 0.0, 0.0]
    assert lr.steps == 1 and "q" in mmq.learners()


def test_read_run_frames(tmp_path):
    mmq.run("paper-3x3", learner="q", delay="none", steps=2000, seeds=2, window=500,
            out=str(tmp_path))
    run = mmq.read_run(tmp_path)
    assert run.summary["config"]["seeds"] == 2
    assert sorted(set(run.metrics["seed"])) == [0, 1]
    assert len(run.metrics) == 8 and run.seeds["reward/earned_total"].shape == (2,)
    pd = pytest.importorskip("pandas")
    assert isinstance(run.metrics_df, pd.DataFrame) and len(run.metrics_df) == 8
