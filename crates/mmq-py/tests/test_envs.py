"""The single environments: Gymnasium's checker, hand-computed steps and delays, the
policies for rewards in flight, seeded determinism, info keys."""

import math

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import mmq


@pytest.mark.parametrize("env_id", ["mmq/Grid-v0", "mmq/Robot-v0"])
@pytest.mark.parametrize("delay", ["none", "poisson:13"])
@pytest.mark.parametrize("observation", ["state", "pose"])
def test_check_env(env_id, delay, observation):
    env = gym.make(env_id, world="paper-5x5", delay=delay, observation=observation)
    check_env(env.unwrapped, skip_render_check=True)


def test_registered_with_time_limits():
    assert gym.spec("mmq/Grid-v0").max_episode_steps == 1000
    assert gym.spec("mmq/Robot-v0").max_episode_steps == 200


def walk(env, actions):
    out = []
    for a in actions:
        obs, r, term, trunc, info = env.step(a)
        assert term is False
        out.append((obs, r, trunc, info))
    return out


N, E, S, W = 0, 1, 2, 3


def test_grid_steps_and_const_delay_by_hand():
    # paper-3x3: G = 0 (top left), S = 8 (bottom right).
    env = gym.make("mmq/Grid-v0", world="paper-3x3", delay="const:2", start="respawn")
    obs, info = env.reset(seed=5)
    assert obs == 8 and info["t"] == 0
    steps = walk(env, [E, N, N, W, W, S, S, S])
    states = [s[0] for s in steps]
    # E bumps the wall; N, N, W, W reach G; any action in G: +10, to S; S, S from 8 bump.
    assert states == [8, 5, 2, 1, 0, 8, 8, 8]
    emitted = [s[3]["emitted"] for s in steps]
    assert emitted == [-1.0, 0.0, 0.0, 0.0, 0.0, 10.0, -1.0, -1.0]
    assert [s[3]["event"] for s in steps] == [
        "wall", "moved", "moved", "moved", "moved", "goal", "wall", "wall"
    ]
    delivered = [s[1] for s in steps]
    # Every emission arrives two steps later.
    assert delivered == [0.0, 0.0, -1.0, 0.0, 0.0, 0.0, 0.0, 10.0]
    d = steps[7][3]["deliveries"]
    assert d == [{"t_emit": 5, "delay_steps": 2, "delay_s": pytest.approx(0.2), "value": 10.0}]
    assert steps[5][3]["delay_steps"] == 2 and steps[4][3]["delay_steps"] == -1
    assert steps[7][3]["t"] == 7
    assert steps[7][3]["sim_time_s"] == pytest.approx(0.8)
    # Conservation: emitted = delivered + in flight.
    assert sum(emitted) == pytest.approx(sum(delivered) + steps[-1][3]["in_flight"])
    assert steps[-1][3]["in_flight"] == -2.0
    assert "true_state" not in steps[-1][3]


@pytest.mark.parametrize("mode", ["drop", "flush", "carry"])
def test_rewards_in_flight_at_truncation(mode):
    # The goal's +10 is emitted at t = 4 with delay 5 (due at t = 9); the episode is cut
    # after 6 steps.
    env = gym.make(
        "mmq/Grid-v0", world="paper-3x3", delay="const:5", start="respawn",
        in_flight=mode, max_episode_steps=6, episode_steps=6,
    )
    env.reset(seed=0)
    steps = walk(env, [N, N, W, W, N, N])
    assert [s[2] for s in steps] == [False] * 5 + [True]
    first = [s[1] for s in steps]
    env.reset()
    second = [s[1] for s in walk(env, [E, E, E, E, E])]
    # E from S bumps: −1 every step, due 5 steps later (after this window).
    if mode == "drop":
        assert first == [0.0] * 6 and second == [0.0] * 5
    elif mode == "flush":
        assert first == [0.0] * 5 + [10.0]
        assert [f["value"] for f in steps[-1][3]["flushed"]] == [10.0]
        assert second == [0.0] * 5
    else:
        # Carried: the channel keeps its clock, t = 6, 7, 8, 9: the +10 arrives at the
        # fourth step of the next episode.
        assert first == [0.0] * 6
        assert second == [0.0, 0.0, 0.0, 10.0, 0.0]


def test_flush_needs_the_episode_length():
    with pytest.raises(mmq.ConfigError, match="episode_steps"):
        gym.make("mmq/Grid-v0", in_flight="flush")
    env = gym.make("mmq/Grid-v0", world="paper-3x3", episode_steps=3, max_episode_steps=-1)
    env.reset(seed=0)
    assert [env.step(0)[3] for _ in range(3)] == [False, False, True]


def test_same_seed_same_trajectory_and_seeds_differ():
    def traj(seed, delay="poisson:5"):
        env = gym.make("mmq/Grid-v0", world="paper-9x9", delay=delay)
        obs, _ = env.reset(seed=seed)
        rng = np.random.default_rng(1)
        out = [obs]
        for a in rng.integers(0, 4, size=3000):
            o, r, _, _, info = env.step(int(a))
            out.append((o, r, info["emitted"], info["delay_steps"]))
        return out

    assert traj(3) == traj(3)
    starts = {traj(s)[0] for s in range(12)}
    assert len(starts) > 3, "the random start rule should give different starts"
    assert traj(3) != traj(4)


def test_reset_without_seed_follows_the_chain():
    env = gym.make("mmq/Grid-v0", world="paper-9x9", delay="poisson:5")
    _, i0 = env.reset(seed=11)
    _, i1 = env.reset()
    assert i0["seed"] == 11 and i1["seed"] == mmq.next_seed(11)
    other = gym.make("mmq/Grid-v0", world="paper-9x9", delay="poisson:5")
    o2, _ = other.reset(seed=mmq.next_seed(11))
    assert o2 == env.unwrapped._state


def test_robot_info_and_pose_observation():
    env = gym.make("mmq/Robot-v0", world="paper-3x3", delay="const:1", observation="pose",
                   start="respawn")
    obs, info = env.reset(seed=0)
    assert obs["state"] == 8
    x, y, th = obs["pose"]
    # Cell 8 is row 2, column 2 of a 3×3 world of 0.5 m cells, y up from the bottom.
    assert (x, y) == pytest.approx((1.25, 0.25), abs=1e-6)
    obs, r, term, trunc, info = env.step(N)
    assert obs["state"] == 5 and info["event"] == "moved"
    assert obs["pose"][1] == pytest.approx(0.75, abs=0.05)
    assert info["sim_time_s"] > 0.5 and obs["time"][0] == pytest.approx(info["sim_time_s"])
    assert env.observation_space.contains(obs)


def test_robot_overrides_change_the_robot():
    slow = gym.make("mmq/Robot-v0", world="paper-3x3", delay="none", start="respawn",
                    overrides={"max_speed_mps": 0.1})
    fast = gym.make("mmq/Robot-v0", world="paper-3x3", delay="none", start="respawn")
    slow.reset(seed=0)
    fast.reset(seed=0)
    ts = slow.step(N)[4]["sim_time_s"]
    tf = fast.step(N)[4]["sim_time_s"]
    assert ts > tf * 1.5, (ts, tf)


def test_render_ansi():
    env = gym.make("mmq/Grid-v0", world="paper-3x3", start="respawn", render_mode="ansi")
    env.reset(seed=0)
    assert env.render() == "G..\n...\n..A\n"


def test_optimum_is_exact():
    o = mmq.optimum("paper-9x9")
    assert o["gain"] == pytest.approx(10 / 17)
    assert "paper-9x9" in mmq.world_names()
    assert math.isclose(mmq.optimum("paper-3x3")["gain"], 10 / 5)


def test_world_names_are_the_shipped_worlds_and_the_docs_list_them():
    from conftest import ROOT

    names = mmq.world_names()
    assert sorted(names) == sorted(p.stem for p in (ROOT / "worlds").glob("*.toml"))
    assert len(names) == 8
    for name in names:
        env = gym.make("mmq/Grid-v0", world=name, delay="none")
        assert env.unwrapped.world_name == name
    docs = (ROOT / "docs/python.md").read_text()
    line = next(x for x in docs.splitlines() if x.startswith("| `world` |"))
    listed = line.split("mmq.world_names()`:")[1].split(")")[0]
    assert [w.strip() for w in listed.split(",")] == sorted(names)
