"""Python agents on the benchmark suite (`mmq.suite.evaluate`, docs/suite.md "Python
agents").

- A tabular Q-learning agent in NumPy (the built-in `q`'s equation and parameters) on
  lite-tier tasks of v1 writes a results file that validates against the shipped JSON
  Schema, and its per-task mean fraction of the optimum lies within the 95 % interval of
  the built-in `q` on the same tasks (run by the CLI on a suite file of those tasks).
- An agent that raises on one seed fails that seed only, with the error's text; bad
  actions and seeds over their time limit fail their seeds; bad tier, task and suite
  names raise mmq.ConfigError.
- An evaluation stopped by KeyboardInterrupt, and one of a subset of the tasks, resume
  into the results of one uninterrupted run.

All but the first run on a tiny suite file of the same form as v1."""

import json
import os
import re
import subprocess
from pathlib import Path

import numpy as np
import pytest

import mmq
from conftest import ROOT, mmq_bin

V1 = ROOT / "worlds/suites/v1/suite.toml"

# Two small grid tasks and a robot task, a few thousand steps each.
TINY = """suite = "v1"
[tier.lite]
description = "tiny"
[tier.full]
description = "tiny, more seeds"

[[task]]
name = "five-poisson2"
world = "paper-5x5"
delay = "poisson:2"
max_delay = 6
epsilon = 0.05
q0 = 10
lite = { steps = 3000, seeds = [0, 1, 2, 3] }
full = { steps = 3000, seeds = 5 }

[[task]]
name = "three-uniform"
world = "paper-3x3"
delay = "uniform:0:4"
max_delay = 6
epsilon = 0.05
q0 = 10
lite = { steps = 2000, seeds = [0, 1, 2] }
full = { steps = 2000, seeds = 5 }

[[task]]
name = "robot-five"
world = "paper-5x5"
env = "robot"
robot = "profile=ideal"
delay = "poisson:2"
max_delay = 6
epsilon = 0.05
q0 = 10
eval_steps = 50
lite = { steps = 300, seeds = [0, 1] }
full = { steps = 300, seeds = 5 }
"""


class QAgent:
    """Tabular Q-learning, eq. (2) of the paper: Q(s,a) += α (r + γ max Q(s') − Q(s,a)),
    ε-greedy with ties broken at random; α 0.1, γ 0.9, ε and q0 as the task suggests."""

    def __init__(self, task: mmq.suite.Task):
        self.q = np.full((task.n_states, task.n_actions), float(task.q0))
        self.eps = task.epsilon
        self.rng = np.random.default_rng(task.seed)

    def greedy(self, state):
        row = self.q[state]
        best = np.flatnonzero(row == row.max())
        return int(best[0]) if len(best) == 1 else int(self.rng.choice(best))

    def act(self, state):
        if self.rng.random() < self.eps:
            return int(self.rng.integers(self.q.shape[1]))
        return self.greedy(state)

    def observe(self, state, action, reward, next_state, info):
        q = self.q
        q[state, action] += 0.1 * (reward + 0.9 * q[next_state].max() - q[state, action])


def _tiny(tmp: Path) -> str:
    p = tmp / "tiny.toml"
    p.write_text(TINY)
    return str(p)


def _scores(r: dict) -> dict:
    return {t["task"]: t["seeds"] for t in r["tasks"]}


def _validate(r: dict) -> None:
    try:
        import jsonschema
    except ImportError:
        if os.environ.get("CI") == "true":
            pytest.fail("CI=true: jsonschema is required")
        pytest.skip("jsonschema is not installed")
    schema = json.loads((ROOT / "worlds/suites/results.schema.json").read_text())
    jsonschema.validate(r, schema, cls=jsonschema.Draft202012Validator)


def _v1_subset(names: list[str], path: Path) -> None:
    """A suite file with only the named tasks of v1, each as v1 gives it."""
    text = V1.read_text()
    head, *blocks = text.split("\n[[task]]\n")
    keep = [b for b in blocks if re.search(r'^name = "([^"]+)"', b, re.M).group(1) in names]
    assert len(keep) == len(names)
    path.write_text(head + "".join("\n[[task]]\n" + b for b in keep))


# Tasks of v1 the Q agent is compared on: the grid ones (the robot's physics would
# double the test's time; 30 seeds of 50,000 steps take ~10 s here).
COMPARED = [
    "paper-9x9-poisson13",
    "paper-9x9-uniform",
    "paper-9x9-mixture",
    "paper-9x9-wifi-like",
    "maze-15x15-poisson13",
    "open-30x30-poisson13",
]


def test_q_agent_matches_the_builtin_q(tmp_path):
    r = mmq.suite.evaluate(QAgent, "lite", out=tmp_path / "py", name="numpy-q", tasks=COMPARED)
    _validate(r)
    assert r["agent"] == "numpy-q" and r["suite"] == "v1" and r["tier"] == "lite"
    assert r["complete"] is False, "a subset of the tasks is never complete"
    assert [t["task"] for t in r["tasks"]] == COMPARED
    assert json.loads((tmp_path / "py/results.json").read_text()) == r
    suite = tmp_path / "subset.toml"
    _v1_subset(COMPARED, suite)
    done = subprocess.run(
        [mmq_bin(), "suite", "run", "--learner", "q", "--tier", "lite", "--suite", str(suite), "--out", str(tmp_path / "q"), "-q"],
        capture_output=True,
        text=True,
    )
    assert done.returncode == 0, done.stderr
    builtin = _scores(json.loads((tmp_path / "q/results.json").read_text()))
    from scipy import stats  # rliable's dependency

    for task, seeds in _scores(r).items():
        assert all(not s.get("failed") for s in seeds), seeds
        mine = np.array([s["fraction_of_optimum"] for s in seeds])
        theirs = np.array([s["fraction_of_optimum"] for s in builtin[task]])
        assert len(mine) == len(theirs) == 5
        half = stats.t.ppf(0.975, len(theirs) - 1) * theirs.std(ddof=1) / np.sqrt(len(theirs))
        print(f"{task}: numpy-q {mine.mean():.4f}, built-in q {theirs.mean():.4f} ± {half:.4f}")
        assert abs(mine.mean() - theirs.mean()) <= half, (task, mine, theirs)


def test_an_exception_fails_that_seed_only(tmp_path):
    class Raises(QAgent):
        def __init__(self, task):
            super().__init__(task)
            self.boom = task.name == "five-poisson2" and task.seed == 2

        def observe(self, state, action, reward, next_state, info):
            if self.boom and info["t"] == 100:
                raise ValueError("boom at step 100")
            super().observe(state, action, reward, next_state, info)

    r = mmq.suite.evaluate(Raises, out=tmp_path / "o", name="raises", suite=_tiny(tmp_path))
    _validate(r)
    assert r["complete"] is True
    scores = _scores(r)
    assert [len(scores[t]) for t in ("five-poisson2", "three-uniform", "robot-five")] == [4, 3, 2]
    for task, seeds in scores.items():
        for s in seeds:
            if task == "five-poisson2" and s["seed"] == 2:
                assert s["failed"] is True and "fraction_of_optimum" not in s
                assert "ValueError: boom at step 100" in s["error"], s["error"]
                assert "observe(" in s["error"]
            else:
                assert not s.get("failed") and np.isfinite(s["fraction_of_optimum"]), (task, s)
    # The failed seed is kept: a rerun runs nothing and changes nothing.
    again = mmq.suite.evaluate(Raises, out=tmp_path / "o", name="raises", suite=_tiny(tmp_path))
    assert again == r


@pytest.mark.parametrize(
    "answer, says",
    [(99, "returned 99; the actions are 0..3"), ("up", "returned 'up' (str), not an int"), (True, "(bool), not an int")],
)
def test_bad_actions_fail_their_seeds(tmp_path, answer, says):
    class Bad:
        def __init__(self, task):
            pass

        def act(self, state):
            return answer

        def observe(self, *a):
            pass

    r = mmq.suite.evaluate(Bad, out=tmp_path / "o", name="bad", suite=_tiny(tmp_path), tasks=["five-poisson2"])
    seeds = _scores(r)["five-poisson2"]
    assert len(seeds) == 4 and all(s["failed"] and says in s["error"] for s in seeds), seeds


def test_bad_names_raise_config_error(tmp_path):
    with pytest.raises(mmq.ConfigError, match=r"tier.*`medium`"):
        mmq.suite.evaluate(QAgent, "medium", out=tmp_path / "a")
    with pytest.raises(mmq.ConfigError, match=r"tasks.*`nope` is not a task"):
        mmq.suite.evaluate(QAgent, out=tmp_path / "b", tasks=["nope"])
    with pytest.raises(mmq.ConfigError, match=r"suite.*v9"):
        mmq.suite.evaluate(QAgent, out=tmp_path / "c", suite="v9")
    with pytest.raises(mmq.ConfigError, match="make_agent"):
        mmq.suite.evaluate(None, out=tmp_path / "d")
    assert not (tmp_path / "a").exists()


def test_interrupted_and_partial_runs_resume_to_the_uninterrupted_results(tmp_path):
    suite = _tiny(tmp_path)
    whole = mmq.suite.evaluate(QAgent, out=tmp_path / "whole", name="q", suite=suite)
    assert whole["complete"] and sum(len(t["seeds"]) for t in whole["tasks"]) == 9

    steps = {"n": 0}

    class Interrupts(QAgent):
        def observe(self, *a):
            steps["n"] += 1
            if steps["n"] == 7000:
                raise KeyboardInterrupt
            super().observe(*a)

    with pytest.raises(KeyboardInterrupt):
        mmq.suite.evaluate(Interrupts, out=tmp_path / "cut", name="q", suite=suite)
    cut = json.loads((tmp_path / "cut/results.json").read_text())
    assert cut["complete"] is False
    assert sum(len(t["seeds"]) for t in cut["tasks"]) == 2  # two seeds of 3,000 steps
    made = []

    def counted(task):
        made.append((task.name, task.seed))
        return QAgent(task)

    resumed = mmq.suite.evaluate(counted, out=tmp_path / "cut", name="q", suite=suite)
    assert len(made) == 7
    assert resumed["tasks"] == whole["tasks"] and resumed["complete"]

    # A subset of the tasks first, then all of them in the same directory.
    part = mmq.suite.evaluate(QAgent, out=tmp_path / "grow", name="q", suite=suite, tasks=["three-uniform"])
    assert part["complete"] is False and [t["task"] for t in part["tasks"]] == ["three-uniform"]
    made.clear()
    grown = mmq.suite.evaluate(counted, out=tmp_path / "grow", name="q", suite=suite)
    assert sorted({n for n, _ in made}) == ["five-poisson2", "robot-five"]
    assert grown["tasks"] == whole["tasks"] and grown["complete"]
    # Another agent's name in the same directory is refused.
    with pytest.raises(mmq.ConfigError, match="out"):
        mmq.suite.evaluate(QAgent, out=tmp_path / "grow", name="other", suite=suite)


def test_the_task_an_agent_is_told(tmp_path):
    told = []

    class Nothing:
        def __init__(self, task):
            told.append(task)

        def act(self, state):
            return 0

        def observe(self, *a):
            pass

    r = mmq.suite.evaluate(Nothing, out=tmp_path / "o", name="nothing", suite=_tiny(tmp_path), tasks=["three-uniform"])
    assert [t.seed for t in told] == [0, 1, 2]
    t = told[0]
    assert (t.name, t.n_states, t.n_actions, t.max_delay, t.epsilon, t.q0) == ("three-uniform", 9, 4, 6, 0.05, 10.0)
    # Without greedy, act is the greedy policy.
    assert all(s["greedy_fraction_of_optimum"] is not None for s in r["tasks"][0]["seeds"])


def test_a_seed_over_its_time_limit_fails(tmp_path):
    import time

    class Slow(QAgent):
        def act(self, state):
            time.sleep(0.002)
            return super().act(state)

    r = mmq.suite.evaluate(
        Slow, out=tmp_path / "o", name="slow", suite=_tiny(tmp_path), tasks=["three-uniform"], time_limit_s=0.05
    )
    seeds = _scores(r)["three-uniform"]
    assert len(seeds) == 3 and all(s["failed"] and "ran out of time" in s["error"] for s in seeds), seeds
