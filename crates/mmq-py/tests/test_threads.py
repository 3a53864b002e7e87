"""Environments, vector environments and learners are not bound to the thread that made
them: used from another thread (one thread at a time) they give what they give in the
thread that made them."""

import threading

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_match import check_environments_match

import mmq


def in_thread(fn):
    """Runs fn() in a new thread; returns its result or raises what it raised there
    (BaseException included: a pyo3 panic is one)."""
    out = {}

    def work():
        try:
            out["value"] = fn()
        except BaseException as e:  # noqa: BLE001  (re-raised in the caller's thread)
            out["error"] = e

    t = threading.Thread(target=work)
    t.start()
    t.join()
    if "error" in out:
        raise out["error"]
    return out["value"]


def rollout(env, actions):
    return [(o, r, tr, info["emitted"], info["delay_steps"])
            for o, r, _, tr, info in (env.step(int(a)) for a in actions)]


@pytest.mark.parametrize("env_id,delay,steps", [("mmq/Grid-v0", "poisson:5", 2000),
                                                ("mmq/Robot-v0", "poisson:2", 150)])
def test_an_environment_steps_from_another_thread(env_id, delay, steps):
    kw = dict(world="paper-5x5", delay=delay, max_episode_steps=10**6)
    actions = np.random.default_rng(1).integers(0, 4, size=steps)
    here = gym.make(env_id, **kw)
    here.reset(seed=8)
    expected = rollout(here, actions)
    there = gym.make(env_id, **kw)  # made in this thread ...
    there.reset(seed=8)
    half = steps // 2
    first = in_thread(lambda: rollout(there, actions[:half]))  # ... stepped in another
    assert first + rollout(there, actions[half:]) == expected  # ... and back here
    # Gymnasium's own comparison, run in a third thread over environments made here.
    a, b = gym.make(env_id, **kw), gym.make(env_id, **kw)
    in_thread(lambda: check_environments_match(a, b, steps, seed=4))


def test_a_vector_environment_and_a_learner_work_from_another_thread():
    kw = dict(world="paper-5x5", delay="poisson:5", max_episode_steps=60)
    actions = np.random.default_rng(2).integers(0, 4, size=(500, 3))

    def run(venv):
        venv.reset(seed=5)
        return [venv.step(a)[:4] for a in actions]

    expected = run(gym.make_vec("mmq/Grid-v0", 3, vectorization_mode="vector_entry_point", **kw))
    venv = gym.make_vec("mmq/Grid-v0", 3, vectorization_mode="vector_entry_point", **kw)
    got = in_thread(lambda: run(venv))
    for e, g in zip(expected, got):
        assert all(np.array_equal(x, y) for x, y in zip(e, g))

    def learn(lr):
        rng = np.random.default_rng(3)
        s = 0
        for _ in range(3000):
            a = lr.act(s)
            s2 = int(rng.integers(0, 25))
            lr.observe(s, a, float(rng.normal()), s2)
            s = s2
        return lr.q.copy()

    here = mmq.Learner("mmq", 25, 4, seed=6, max_delay=8)
    there = mmq.Learner("mmq", 25, 4, seed=6, max_delay=8)
    assert np.array_equal(in_thread(lambda: learn(there)), learn(here))
    assert there.steps == 3000 and there.greedy(0) in range(4)
