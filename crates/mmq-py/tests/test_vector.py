"""Vector environments batched in Rust equal N single environments with matching seeds."""

import gymnasium as gym
import numpy as np
import pytest


def single_rollouts(env_id, n, seed, actions, limit, **kw):
    """Environment i reset with seed + i, reset without a seed on the step after a
    truncation (next-step autoreset: that step reports the new state, reward 0)."""
    out_obs, out_rew, out_trunc = [], [], []
    for i in range(n):
        env = gym.make(env_id, max_episode_steps=limit, episode_steps=limit, **kw)
        env.reset(seed=seed + i)
        obs, rew, trunc = [], [], []
        done = False
        for a in actions[:, i]:
            if done:
                o, _ = env.reset()
                r, t = 0.0, False
            else:
                o, r, term, t, _ = env.step(int(a))
                assert not term
            done = t
            obs.append(o)
            rew.append(r)
            trunc.append(t)
        out_obs.append(obs)
        out_rew.append(rew)
        out_trunc.append(trunc)
    return np.array(out_obs).T, np.array(out_rew).T, np.array(out_trunc).T


@pytest.mark.parametrize(
    "env_id,steps,limit,delay,in_flight",
    [
        ("mmq/Grid-v0", 400, 37, "poisson:5", "drop"),
        ("mmq/Grid-v0", 400, 23, "uniform:0:12", "flush"),
        ("mmq/Grid-v0", 300, 29, "poisson:5", "carry"),
        ("mmq/Robot-v0", 24, 7, "poisson:2", "drop"),
    ],
)
def test_vector_equals_single(env_id, steps, limit, delay, in_flight):
    n = 4
    kw = dict(world="paper-5x5", delay=delay, in_flight=in_flight)
    venv = gym.make_vec(env_id, num_envs=n, vectorization_mode="vector_entry_point",
                        max_episode_steps=limit, **kw)
    actions = np.random.default_rng(7).integers(0, 4, size=(steps, n))
    obs0, _ = venv.reset(seed=100)
    obs, rew, trunc = [], [], []
    for a in actions:
        o, r, term, t, info = venv.step(a)
        assert not term.any()
        assert info["emitted"].shape == (n,)
        obs.append(o)
        rew.append(r)
        trunc.append(t)
    sobs, srew, strunc = single_rollouts(env_id, n, 100, actions, limit, **kw)
    assert np.array_equal(np.array(obs), sobs)
    assert np.array_equal(np.array(trunc), strunc)
    assert np.array_equal(np.array(rew), srew)
    assert np.array(trunc).sum() >= n * (steps // (limit + 1)) > 0
    assert np.abs(np.array(rew)).sum() > 0


def test_vector_spaces_and_bad_actions():
    venv = gym.make_vec("mmq/Grid-v0", num_envs=3, vectorization_mode="vector_entry_point",
                        world="paper-9x9")
    assert venv.single_observation_space.n == 81 and venv.single_action_space.n == 4
    obs, _ = venv.reset(seed=0)
    assert obs.dtype == np.int64 and obs.shape == (3,)
    with pytest.raises(ValueError, match="out of range"):
        venv.step(np.array([0, 4, 1]))
    with pytest.raises(ValueError, match="actions"):
        venv.step(np.array([0, 1]))


def test_reset_seed_none_continues_each_chain():
    import mmq

    venv = gym.make_vec("mmq/Grid-v0", num_envs=2, vectorization_mode="vector_entry_point",
                        world="paper-9x9")
    venv.reset(seed=3)
    o1, _ = venv.reset()
    for i in range(2):
        env = gym.make("mmq/Grid-v0", world="paper-9x9")
        o, _ = env.reset(seed=mmq.next_seed(3 + i))
        assert o == o1[i]
