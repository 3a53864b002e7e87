"""Gymnasium's own vector environments over the single environment: every info key has
one type, so `SyncVectorEnv` and `AsyncVectorEnv` (``gym.make_vec(...,
vectorization_mode="sync" | "async")``) step as long as one likes, and equal the
package's vector environment step for step."""

from collections import defaultdict

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import data_equivalence
from gymnasium.utils.env_match import check_environments_match
from gymnasium.vector import AutoresetMode

import mmq  # noqa: F401  (registers the environments)

N = 4
# Steps per case: several episodes each (the grid's episodes are 1,000 steps, the
# robot's 200), so that truncations and autoresets are compared many times over.
STEPS = {"mmq/Grid-v0": 5_000, "mmq/Robot-v0": 2_500}
CASES = [
    ("mmq/Grid-v0", "none"),
    ("mmq/Grid-v0", "poisson:13"),
    ("mmq/Robot-v0", "none"),
    ("mmq/Robot-v0", "poisson:13"),
]


@pytest.mark.parametrize("env_id,delay", CASES)
def test_gymnasium_vector_modes_equal_the_package_vector(env_id, delay):
    kw = dict(world="paper-9x9", delay=delay)
    own = gym.make_vec(env_id, num_envs=N, vectorization_mode="vector_entry_point", **kw)
    sync = gym.make_vec(env_id, num_envs=N, vectorization_mode="sync", **kw)
    asyn = gym.make_vec(env_id, num_envs=N, vectorization_mode="async", **kw)
    venvs = (own, sync, asyn)
    try:
        for v in venvs:
            assert v.metadata["autoreset_mode"] == AutoresetMode.NEXT_STEP
        resets = [v.reset(seed=42) for v in venvs]
        for obs, _ in resets[1:]:
            assert np.array_equal(obs, resets[0][0])
        assert data_equivalence(resets[1][1], resets[2][1])
        seeds = resets[1][1]["seed"]
        assert seeds.dtype == np.uint64 and [int(s) for s in seeds] == [42 + i for i in range(N)]

        steps = STEPS[env_id]
        actions = np.random.default_rng(5).integers(0, 4, size=(steps, N))
        truncations, delivered, delayed, autoresets = 0, 0.0, 0, 0
        for a in actions:
            (o0, r0, te0, tr0, i0), *gyms = [v.step(a) for v in venvs]
            for o, r, te, tr, info in gyms:
                assert np.array_equal(o, o0)
                assert np.array_equal(r, r0)
                assert np.array_equal(te, te0) and not te.any()
                assert np.array_equal(tr, tr0)
                # An environment reset on this step has its reset's info (no "emitted").
                emitted = info.get("emitted", np.zeros(N))
                assert np.array_equal(emitted, i0["emitted"])
            assert data_equivalence(gyms[0][4], gyms[1][4]), "sync and async infos differ"
            info = gyms[0][4]
            if "_emitted" in info:
                stepped = info["_emitted"]
                assert np.array_equal(info["_delay_steps"], stepped)
                assert info["delay_steps"].dtype == np.int64
                assert np.array_equal((info["delay_steps"] >= 0)[stepped],
                                      (info["emitted"] != 0)[stepped])
                delayed += int((info["delay_steps"] > 0).sum())
            if "_seed" in info:
                autoresets += int(info["_seed"].sum())
                assert info["seed"].dtype == np.uint64
            truncations += int(tr0.sum())
            delivered += float(np.abs(r0).sum())
        limit = own.max_episode_steps
        assert truncations == N * ((steps + 1) // (limit + 1)) > 0
        assert autoresets == N * (steps // (limit + 1)) > 0
        assert delivered > 0
        assert (delayed > 0) == (delay != "none")
    finally:
        for v in venvs:
            v.close()


def _info_types(env_id, steps, **kw):
    env = gym.make(env_id, world="paper-5x5", **kw)
    types = defaultdict(set)
    _, info = env.reset(seed=3)
    for k, v in info.items():
        types["reset", k].add(type(v))
    rng = np.random.default_rng(0)
    for a in rng.integers(0, 4, size=steps):
        _, _, _, truncated, info = env.step(int(a))
        for k, v in info.items():
            types[k].add(type(v))
        if truncated:
            _, info = env.reset()
            for k, v in info.items():
                types["reset", k].add(type(v))
    return types


@pytest.mark.parametrize(
    "env_id,steps,kw",
    [
        ("mmq/Grid-v0", 3000, dict(delay="none")),
        ("mmq/Grid-v0", 3000, dict(delay="poisson:5", in_flight="flush", max_episode_steps=97,
                                   episode_steps=97)),
        ("mmq/Grid-v0", 3000, dict(delay="uniform:0:9", in_flight="carry", max_episode_steps=50)),
        ("mmq/Robot-v0", 300, dict(delay="poisson:3", profile="realistic", max_episode_steps=40)),
        ("mmq/Robot-v0", 300, dict(delay="const:2", observation="pose", max_episode_steps=40)),
    ],
)
def test_every_info_key_has_one_type(env_id, steps, kw):
    types = _info_types(env_id, steps, **kw)
    assert {k: t for k, t in types.items() if len(t) != 1} == {}
    numbers = (int, float, np.uint64)
    for key in ("emitted", "delay_steps", "t", "sim_time_s", "in_flight", ("reset", "seed")):
        assert types[key] <= set(numbers), (key, types[key])
    assert types["delay_steps"] == {int} and types["reset", "seed"] == {np.uint64}
    if kw.get("profile") == "realistic":
        assert types["true_state"] == types["believed_state"] == {int}


@pytest.mark.parametrize("env_id,delay,steps", [("mmq/Grid-v0", "poisson:7", 3000),
                                                ("mmq/Robot-v0", "poisson:3", 300)])
def test_two_environments_of_one_seed_match(env_id, delay, steps):
    kw = dict(world="paper-9x9", delay=delay, max_episode_steps=97)
    check_environments_match(gym.make(env_id, **kw), gym.make(env_id, **kw), steps, seed=9)
