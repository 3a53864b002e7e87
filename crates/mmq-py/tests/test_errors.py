"""Bad input from Python raises mmq.ConfigError (a ValueError) naming the argument and
the fix; nothing panics across the boundary."""

import gymnasium as gym
import numpy as np
import pytest

import mmq


@pytest.mark.parametrize(
    "kwargs,arg,fix",
    [
        (dict(world="no-such-world"), "world", "paper-9x9"),
        (dict(delay="poisson:-2"), "delay", "negative"),
        (dict(delay="gauss:3"), "delay", ""),
        (dict(start="middle"), "start", "respawn"),
        (dict(start=999), "start", "free cell"),
        (dict(in_flight="keep"), "in_flight", "carry"),
        (dict(observation="pixels"), "observation", "pose"),
        (dict(preset="kobuki"), "preset", "mmq/Robot-v0"),
    ],
)
def test_grid_arguments(kwargs, arg, fix):
    with pytest.raises(mmq.ConfigError, match=arg) as e:
        gym.make("mmq/Grid-v0", **kwargs)
    assert isinstance(e.value, ValueError)
    assert fix in str(e.value)


@pytest.mark.parametrize(
    "kwargs,arg,fix",
    [
        (dict(preset="roomba"), "preset", "roomba"),
        (dict(overrides={"max_speed_mps": -1.0}), "overrides", "max_speed_mps"),
        (dict(overrides={"no_such_field": 1}), "overrides", "no_such_field"),
        (dict(overrides={"max_speed_mps": object()}), "overrides", "max_speed_mps"),
    ],
)
def test_robot_arguments(kwargs, arg, fix):
    with pytest.raises(mmq.ConfigError) as e:
        gym.make("mmq/Robot-v0", world="paper-3x3", **kwargs)
    assert str(e.value).startswith(arg + ":"), str(e.value)
    assert fix in str(e.value)


def test_learner_settings():
    with pytest.raises(mmq.ConfigError, match="alpha = 1.5"):
        mmq.Learner("q", 9, 4, alpha=1.5)
    with pytest.raises(mmq.ConfigError, match="learner"):
        mmq.Learner("sarsa-x", 9, 4)
    with pytest.raises(mmq.ConfigError, match="gamme"):
        mmq.Learner("q", 9, 4, gamme=0.5)
    with pytest.raises(mmq.ConfigError, match="max_delay"):
        mmq.Learner("mmq", 9, 4, max_delay=10**12)
    with pytest.raises(mmq.ConfigError, match="seed"):
        mmq.Learner("q", 9, 4, seed=-1)
    lr = mmq.Learner("q", 9, 4)
    with pytest.raises(ValueError, match="state"):
        lr.act(9)
    with pytest.raises(ValueError, match="action"):
        lr.observe(0, 4, 0.0, 1)


def test_each_learner_takes_only_its_own_settings():
    # Each learner's own settings are accepted by name ...
    mmq.Learner("mmq", 9, 4, max_delay=5, alpha=1)
    mmq.Learner("fixed", 9, 4, lambda_hat=3)
    mmq.Learner("q-lambda", 9, 4, trace_decay=0.5)
    mmq.Learner("deconv-q", 9, 4, lasso=0.2, max_delay=10, told_delay="poisson:3")
    # ... another learner's are refused with the learners that have them.
    with pytest.raises(mmq.ConfigError, match="max_delay: learner `q` has no such setting") as e:
        mmq.Learner("q", 9, 4, max_delay=5)
    assert "mmq-kernel" in str(e.value)
    with pytest.raises(mmq.ConfigError, match="lasso: learner `mmq` has no such setting") as e:
        mmq.Learner("mmq", 9, 4, lasso=0.2)
    assert "its settings are max_delay" in str(e.value)
    with pytest.raises(mmq.ConfigError, match="trace_decay"):
        mmq.Learner("q-lambda", 9, 4, trace_decay=1.5)
    with pytest.raises(mmq.ConfigError, match="lambda_hat"):
        mmq.run("paper-3x3", learner="mmq", steps=10, lambda_hat=3)


def test_run_arguments(tmp_path):
    with pytest.raises(mmq.ConfigError, match="steps"):
        mmq.run("paper-3x3", steps=0)
    with pytest.raises(mmq.ConfigError, match="seeds"):
        mmq.run("paper-3x3", steps=10, seeds=-1)
    with pytest.raises(mmq.ConfigError, match="window"):
        mmq.run("paper-3x3", steps=10, window=1.5)
    with pytest.raises(mmq.ConfigError, match="delay"):
        mmq.run("paper-3x3", delay="poisson:x", steps=10)
    with pytest.raises(mmq.ConfigError, match="epsilon"):
        mmq.run("paper-3x3", steps=10, epsilon=2.0)
    with pytest.raises(mmq.ConfigError, match="env"):
        mmq.run("paper-3x3", steps=10, env="boat")
    with pytest.raises(mmq.ConfigError, match="path"):
        mmq.read_run(tmp_path)
    with pytest.raises(mmq.ConfigError, match="file"):
        mmq.read_recording(tmp_path / "none.mcap")


def test_bad_actions_and_seeds():
    env = gym.make("mmq/Grid-v0")
    env.reset(seed=0)
    with pytest.raises(ValueError, match="out of range"):
        env.unwrapped.step(7)
    with pytest.raises(TypeError):
        env.unwrapped.step("north")
    with pytest.raises(mmq.ConfigError, match="seed"):
        env.unwrapped._core.reset(-5)
    assert env.unwrapped.step(np.int64(2))[0] is not None
