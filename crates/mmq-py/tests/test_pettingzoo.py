"""``mmq.pettingzoo.swarm_v0``: PettingZoo's parallel API test, seeded determinism,
asynchronous decisions (robots absent from a step), rewards delayed by the radio
consultation, one robot equal to ``mmq/Robot-v0``, independent learners from Python
equal to the CLI's swarm run, and bad settings."""

import pickle
import warnings

import gymnasium as gym
import numpy as np
import pytest

pytest.importorskip("pettingzoo")

from pettingzoo.test import parallel_api_test  # noqa: E402

import mmq  # noqa: E402
from conftest import cli  # noqa: E402
from mmq.pettingzoo import swarm_v0  # noqa: E402

REALISTIC = {"profile": "realistic"}


def play(env, seed, steps, action_seed=0):
    """`steps` calls of `step` with seeded random actions for the waiting robots; the
    returned dictionaries, in order."""
    rng = np.random.default_rng(action_seed)
    obs, infos = env.reset(seed=seed)
    out = [(obs, infos)]
    for _ in range(steps):
        if not env.agents:
            break
        actions = {a: int(rng.integers(env.action_space(a).n)) for a in sorted(obs)}
        obs, rewards, terms, truncs, infos = env.step(actions)
        out.append((obs, rewards, terms, truncs, infos))
    return out


@pytest.mark.parametrize("robots", [1, 4, 16])
@pytest.mark.parametrize("robot", [None, REALISTIC], ids=["ideal", "realistic"])
def test_parallel_api(robots, robot):
    env = swarm_v0.parallel_env(robots=robots, robot=robot, max_steps=8, consult="none")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        parallel_api_test(env, num_cycles=8 * robots + 10)
    # A robot still moving is absent from a step's dictionaries (the documented
    # convention): the API test warns about it and goes on. Nothing else is reported.
    messages = {str(w.message) for w in caught}
    absent = {m for m in messages if m.startswith("Live agent was not given")}
    assert messages == absent
    assert bool(absent) == (robots > 1)
    assert env.agents == []  # every robot truncated after its 8 decisions
    assert env.metadata["name"] == "mmq_swarm_v0"
    assert env.metadata["is_parallelizable"] is True


def test_parallel_api_with_consultation():
    env = swarm_v0.parallel_env(robots=6, consult="peers", k=2, radio_range_m=3.0, loss=0.1,
                                max_steps=10)
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message="Live agent was not given")
        parallel_api_test(env, num_cycles=100)


def test_spaces_and_agents():
    env = swarm_v0.parallel_env(robots=3)
    assert env.possible_agents == ["robot_0", "robot_1", "robot_2"]
    assert env.observation_space("robot_1") == gym.spaces.Discrete(81)
    assert env.action_space("robot_2").n == len(env.action_names)
    obs, infos = env.reset(seed=1)
    assert set(obs) == set(infos) == set(env.agents) == set(env.possible_agents)
    assert all(type(s) is int for s in obs.values())
    assert all(type(i["seed"]) is int and i["seed"] == 1 for i in infos.values())


def test_same_seed_same_dicts_and_another_seed_differs():
    def make():
        return swarm_v0.parallel_env(robots=4, consult="peers", k=1, radio_range_m=2.0,
                                     loss=0.2, max_steps=60)

    a = play(make(), 3, 150)
    b = play(make(), 3, 150)
    assert a == b
    c = play(make(), 4, 150)
    assert a != c
    # The same environment reset with the same seed replays it too.
    env = make()
    play(env, 9, 40)
    assert play(env, 3, 150) == a


def test_robots_are_absent_while_moving_and_truncated_once():
    env = swarm_v0.parallel_env(robots=4, max_steps=30)
    rng = np.random.default_rng(0)
    obs, _ = env.reset(seed=0)
    absent = 0
    decisions = {a: 0 for a in env.possible_agents}
    truncated = []
    while env.agents:
        alive = list(env.agents)
        actions = {a: int(rng.integers(env.action_space(a).n)) for a in obs}
        obs, rewards, terms, truncs, infos = env.step(actions)
        assert obs and set(obs) == set(rewards) == set(infos) == set(terms) == set(truncs)
        assert not any(terms.values())
        for a in set(alive) - set(obs):  # moving: absent, and reads as neither flag
            assert a not in terms and not terms[a] and not truncs[a] and truncs.get(a) is None
        with pytest.raises(KeyError):
            terms["robot_9"]
        assert pickle.loads(pickle.dumps(truncs)) == truncs
        absent += len(obs) < len(alive)
        for a, info in infos.items():
            assert info["decision"] == decisions[a]
            decisions[a] += 1
        truncated += [a for a, t in truncs.items() if t]
        assert set(env.agents) == set(alive) - {a for a, t in truncs.items() if t}
    assert absent > 0
    assert sorted(truncated) == env.possible_agents
    assert all(n == 30 for n in decisions.values())
    assert env.step({}) == ({}, {}, {}, {}, {})


def test_info_keys_have_one_type():
    env = swarm_v0.parallel_env(robots=4, consult="peers", k=3, radio_range_m=1.0, loss=0.3,
                                robot=REALISTIC, max_steps=None)
    types: dict[str, type] = {}
    for rec in play(env, 5, 400)[1:]:
        obs, rewards, _, _, infos = rec
        for a, info in infos.items():
            assert type(obs[a]) is int and type(rewards[a]) is float
            assert info["believed_state"] == obs[a]
            assert type(info["true_state"]) is int
            for k, v in info.items():
                assert types.setdefault(k, type(v)) is type(v), k
            for d in info["deliveries"]:
                assert [type(d[k]) for k in ("decision", "value", "emitted_s", "delay_s", "hops")] \
                    == [int, float, float, float, int]
            if info["lost"]:
                assert info["consult_delay_s"] == -1.0 and info["consult_hops"] == -1
    assert set(types) == {"decision", "emitted", "event", "sim_time_s", "deliveries",
                          "consult_delay_s", "consult_hops", "lost", "in_flight",
                          "true_state", "believed_state"}


def test_rewards_are_delayed_by_the_consultation():
    env = swarm_v0.parallel_env(robots=4, consult="peers", k=1, radio_range_m=10.0,
                                hop_delay="const:2s", max_steps=None)
    delays, differs = [], 0
    emitted = delivered = 0.0
    for rec in play(env, 0, 600)[1:]:
        _, rewards, _, _, infos = rec
        for a, info in infos.items():
            emitted += info["emitted"]
            delivered += rewards[a]
            differs += info["emitted"] != rewards[a]
            assert rewards[a] == pytest.approx(sum(d["value"] for d in info["deliveries"]))
            for d in info["deliveries"]:
                delays.append(d["delay_s"])
                assert d["hops"] >= 1  # the reply's one-way hops
                assert info["sim_time_s"] >= d["emitted_s"] + d["delay_s"] - 1e-9
            if info["emitted"] != 0.0:
                assert info["consult_delay_s"] >= 4.0 - 1e-9  # a request and a reply, 2 s a hop
    assert delays and min(delays) >= 4.0 - 1e-9
    assert differs > 0
    # Nothing is lost in range: earned = delivered + in flight.
    assert emitted == pytest.approx(delivered + sum(env.in_flight().values()))
    assert sum(d["lost"] for d in env.delays().values()) == 0


@pytest.mark.parametrize("profile", ["ideal", "realistic"])
def test_one_robot_without_consultation_is_robot_v0(profile):
    seed, steps = 11, 300
    single = gym.make("mmq/Robot-v0", world="paper-9x9", delay="none", profile=profile,
                      max_episode_steps=steps + 1).unwrapped
    swarm = swarm_v0.parallel_env(world="paper-9x9", robots=1, consult="none",
                                  robot={"profile": profile}, max_steps=None)
    s, _ = single.reset(seed=seed)
    obs, _ = swarm.reset(seed=seed)
    assert obs == {"robot_0": s}
    rng = np.random.default_rng(1)
    nonzero = 0
    for _ in range(steps):
        a = int(rng.integers(single.action_space.n))
        s, r, _, _, info = single.step(a)
        obs, rewards, _, _, sinfo = swarm.step({"robot_0": a})
        si = sinfo["robot_0"]
        assert obs["robot_0"] == s
        assert rewards["robot_0"] == r and si["emitted"] == info["emitted"]
        assert si["event"] == info["event"]
        assert si["sim_time_s"] == info["sim_time_s"]
        assert si.get("true_state") == info.get("true_state")
        nonzero += r != 0.0
    assert nonzero > 0


def test_robot_settings_as_a_list_equal_a_dict():
    as_list = ["profile=realistic", "noise.slip_probability=0.2"]
    as_dict = {"profile": "realistic", "noise.slip_probability": 0.2}
    a = play(swarm_v0.parallel_env(robots=2, robot=as_list), 2, 50)
    b = play(swarm_v0.parallel_env(robots=2, robot=as_dict), 2, 50)
    assert a == b
    c = play(swarm_v0.parallel_env(robots=2, robot={"profile": "realistic"}), 2, 50)
    assert a != c  # the slip setting reached the robots


def test_render_ansi():
    env = swarm_v0.parallel_env(robots=3, render_mode="ansi", starts=[[1, 2], [5, 5], [9, 8]])
    env.reset(seed=0)
    text = env.render()
    rows = text.splitlines()
    assert rows[0][1] == "0" and rows[4][4] == "1" and rows[8][7] == "2"


@pytest.mark.parametrize(
    "kwargs, field",
    [
        ({"robots": 0}, "robots"),
        ({"robots": 65}, "robots"),
        ({"robots": 3, "consult": "peers", "k": 3}, "k"),
        ({"robots": 1, "consult": "peers"}, "k"),
        ({"consult": "gossip"}, "consult"),
        ({"radio_range_m": -1.0}, "radio_range_m"),
        ({"hop_delay": "poisson:3"}, "hop_delay"),
        ({"loss": 1.5}, "loss"),
        ({"starts": [[1, 1]]}, "starts"),
        ({"colour": "red"}, "colour"),
        ({"learners": "shared"}, "learners"),
        ({"robot": {"max_speed_mps": -1.0}}, "robot"),
        ({"robot": ["nonsense=1"]}, "robot"),
        ({"robot": 3}, "robot"),
        ({"world": "paper-9"}, "world"),
        ({"max_steps": 0}, "max_steps"),
        ({"render_mode": "human"}, "render_mode"),
    ],
)
def test_bad_settings_name_the_field(kwargs, field):
    with pytest.raises(mmq.ConfigError) as e:
        swarm_v0.parallel_env(**kwargs)
    assert isinstance(e.value, Exception)
    assert str(e.value).startswith(f"{field}: "), str(e.value)


def test_bad_actions():
    env = swarm_v0.parallel_env(robots=2, max_steps=None)
    env.reset(seed=0)
    with pytest.raises(ValueError, match="robot_1 waits for an action"):
        env.step({"robot_0": 0})
    with pytest.raises(ValueError, match="out of range"):
        env.step({"robot_0": 0, "robot_1": 99})
    with pytest.raises(ValueError, match="out of range"):
        env.step({"robot_0": True, "robot_1": 0})
    # A refused call started nothing: both robots still wait.
    obs, *_ = env.step({"robot_0": np.int64(0), "robot_1": 1})
    assert obs
    env.reset(seed=0)
    with pytest.raises(ValueError, match="not an agent"):
        env.step({"robot_0": 0, "robot_1": 0, "robot_7": 0})


def test_robot_seed_is_the_swarms():
    # Robot 0 has the seed's own streams; the others differ (the Rust function's values).
    assert swarm_v0.robot_seed(7, 0) == 7
    seeds = {swarm_v0.robot_seed(7, i) for i in range(64)}
    assert len(seeds) == 64


def test_independent_learners_from_python_equal_the_cli(tmp_path):
    """The loop of `mmq run --env swarm` (an independent Q-learner per robot, each
    acting when its primitive ends, parked after its budget) driven from Python through
    swarm_v0 gives robot 0's Q-table of the CLI bit for bit: the same seed is the same
    swarm trajectory, consultation and bumps included."""
    seed, steps = 5, 300
    swarm = {"robots": 3, "consult": "peers", "k": 1, "radio_range_m": 2.0,
             "hop_delay": "const:0.5s", "loss": 0.1}
    settings = {"alpha": 0.1, "gamma": 0.9, "epsilon": 0.2, "q0": 0.0}
    out = tmp_path / "cli"
    cli("run", "--world", "worlds/paper-5x5.toml", "--env", "swarm", "--learner", "q",
        "--steps", str(steps), "--seeds", "1", "--seed", str(seed), "--no-baseline",
        *[x for k, v in swarm.items() for x in ("--swarm", f"{k}={v}")],
        *[x for k, v in settings.items() for x in (f"--{k.replace('_', '-')}", str(v))],
        "-q", "--out", str(out))
    expected = np.load(out / f"q_seed{seed}.npy")

    env = swarm_v0.parallel_env(world="paper-5x5", max_steps=steps, **swarm)
    learners = {a: mmq.Learner("q", env.observation_space(a).n, env.action_space(a).n,
                               seed=swarm_v0.robot_seed(seed, i), **settings)
                for i, a in enumerate(env.possible_agents)}
    obs, _ = env.reset(seed=seed)
    state = dict(obs)
    actions = {a: learners[a].act(s) for a, s in obs.items()}
    delayed = 0
    while env.agents:
        obs, rewards, _, truncs, infos = env.step(actions)
        for a, s2 in obs.items():
            learners[a].observe(state[a], actions[a], rewards[a], s2, infos[a]["sim_time_s"])
            delayed += rewards[a] != infos[a]["emitted"]
            state[a] = s2
            if not truncs[a]:
                actions[a] = learners[a].act(s2)
    assert delayed > 0
    q = learners["robot_0"].q
    assert q.shape == expected.shape
    assert np.array_equal(q, expected)
    assert (expected != 0.0).sum() > 10
