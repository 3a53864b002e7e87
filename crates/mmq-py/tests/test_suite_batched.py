"""Batched Python agents on the benchmark suite (`mmq.suite.evaluate` with `act_batch`
and `observe_batch`, docs/suite.md "Python agents").

- A tabular Q-learning agent vectorised over its seeds in NumPy gives, seed for seed,
  exactly the results (every stored metric but the wall times) of the same agent
  written for one seed: each seed draws its randomness from its own stream in the same
  order either way, and the environment and delays are mmq's.
- An exception in a batched call fails every seed of its batch with the text while the
  other tasks go on; a bad action fails its seed only, the batch's other seeds ending as
  they would without it; an answer that is not one action per seed, and a batch over
  its time limit, fail the batch.
- A batch stopped by KeyboardInterrupt stores nothing; the next call runs it again, to
  the results of one uninterrupted run.
- Every results file validates against the shipped JSON Schema."""

import json

import numpy as np
import pytest

import mmq
from test_suite_python import _scores, _tiny, _validate

# Rows of random numbers drawn at a time: per step, the exploration draw, the random
# action's draw and one tie-breaking key per action.
BLOCK = 1024


class OneQ:
    """Tabular Q-learning for one seed (α 0.1, γ 0.9, ε and q0 as the task suggests),
    ε-greedy with ties broken by random keys, its randomness drawn from the seed's
    stream in blocks of rows, one row per call of act or greedy."""

    def __init__(self, task):
        self.q = np.full((task.n_states, task.n_actions), float(task.q0))
        self.eps = task.epsilon
        self.rng = np.random.default_rng(task.seed)
        self.rows, self.k = None, BLOCK

    def _row(self):
        if self.k == BLOCK:
            self.rows, self.k = self.rng.random((BLOCK, 2 + self.q.shape[1])), 0
        self.k += 1
        return self.rows[self.k - 1]

    def greedy(self, state):
        row = self._row()
        q = self.q[state]
        best = np.flatnonzero(q == q.max())
        return int(best[np.argmax(row[2:][best])])

    def act(self, state):
        row = self._row()
        if row[0] < self.eps:
            return min(int(row[1] * self.q.shape[1]), self.q.shape[1] - 1)
        q = self.q[state]
        best = np.flatnonzero(q == q.max())
        return int(best[np.argmax(row[2:][best])])

    def observe(self, state, action, reward, next_state, info):
        q = self.q
        q[state, action] += 0.1 * (reward + 0.9 * q[next_state].max() - q[state, action])


class BatchQ:
    """OneQ for all the seeds of a task at once: one Q table per seed, every step
    vectorised over the seeds; seed i draws from its own stream as OneQ does."""

    def __init__(self, task):
        n = len(task.seeds)
        self.seeds = task.seeds
        self.q = np.full((n, task.n_states, task.n_actions), float(task.q0))
        self.eps = task.epsilon
        self.rngs = [np.random.default_rng(s) for s in task.seeds]
        self.idx = np.arange(n)
        self.rows, self.k = None, BLOCK

    def _rows(self):
        if self.k == BLOCK:
            na = self.q.shape[2]
            self.rows, self.k = np.stack([r.random((BLOCK, 2 + na)) for r in self.rngs]), 0
        self.k += 1
        return self.rows[:, self.k - 1]

    def _greedy(self, states, rows):
        q = self.q[self.idx, states]
        keys = np.where(q == q.max(axis=1, keepdims=True), rows[:, 2:], -1.0)
        return keys.argmax(axis=1)

    def greedy_batch(self, states):
        return self._greedy(states, self._rows())

    def act_batch(self, states):
        rows = self._rows()
        na = self.q.shape[2]
        explore = np.minimum((rows[:, 1] * na).astype(np.int64), na - 1)
        return np.where(rows[:, 0] < self.eps, explore, self._greedy(states, rows))

    def observe_batch(self, states, actions, rewards, next_states, infos):
        q, i = self.q, self.idx
        target = rewards + 0.9 * q[i, next_states].max(axis=1)
        q[i, states, actions] += 0.1 * (target - q[i, states, actions])


def _metrics(out):
    """Every stored metric of every seed but the wall times: {(cell, seed file): metrics}."""
    got = {}
    for f in sorted(out.glob("cells/*/seed-*.json")):
        m = json.loads(f.read_text())
        if "metrics" in m:
            m["metrics"] = {k: v for k, v in m["metrics"].items() if not k.startswith("time/")}
        got[(f.parent.name, f.name)] = m
    return got


def _same_as_one_seed_agents(tmp_path, **kw):
    made = []

    def batched(task):
        made.append((task.name, task.seed, task.seeds))
        return BatchQ(task)

    b = mmq.suite.evaluate(batched, out=tmp_path / "batched", name="q", **kw)
    one = mmq.suite.evaluate(OneQ, out=tmp_path / "one", name="q", **kw)
    _validate(b)
    for task in b["tasks"]:
        assert all(not s.get("failed") and np.isfinite(s["fraction_of_optimum"]) for s in task["seeds"]), task
    assert b == one
    mb, mo = _metrics(tmp_path / "batched"), _metrics(tmp_path / "one")
    assert len(mb) == sum(len(t["seeds"]) for t in b["tasks"]) and mb == mo
    return made, b


def test_a_batched_agent_gives_each_seed_its_one_seed_results(tmp_path):
    made, r = _same_as_one_seed_agents(tmp_path, suite=_tiny(tmp_path))
    # Made once per task, for all its seeds (grid and robot tasks).
    assert made == [
        ("five-poisson2", 0, (0, 1, 2, 3)),
        ("three-uniform", 0, (0, 1, 2)),
        ("robot-five", 0, (0, 1)),
    ]
    assert r["complete"] is True


def test_a_batched_agent_on_a_lite_task_of_v1(tmp_path):
    made, r = _same_as_one_seed_agents(tmp_path, tasks=["paper-9x9-poisson13"])
    assert made == [("paper-9x9-poisson13", 0, (0, 1, 2, 3, 4))]
    assert [s["steps"] for s in r["tasks"][0]["seeds"]] == [50_000] * 5


def test_an_exception_in_a_batched_call_fails_its_batch_only(tmp_path):
    class Raises(BatchQ):
        def __init__(self, task):
            super().__init__(task)
            self.boom = task.name == "five-poisson2"

        def observe_batch(self, states, actions, rewards, next_states, infos):
            if self.boom and infos["t"][0] == 100:
                raise ValueError("boom at step 100")
            super().observe_batch(states, actions, rewards, next_states, infos)

    r = mmq.suite.evaluate(Raises, out=tmp_path / "o", name="raises", suite=_tiny(tmp_path))
    _validate(r)
    assert r["complete"] is True
    ok = mmq.suite.evaluate(BatchQ, out=tmp_path / "ok", name="raises", suite=_tiny(tmp_path))
    for task, seeds in _scores(r).items():
        if task == "five-poisson2":
            assert len(seeds) == 4
            for s in seeds:
                assert s["failed"] is True and "fraction_of_optimum" not in s
                assert "ValueError: boom at step 100" in s["error"] and "observe_batch(" in s["error"], s
        else:
            assert seeds == _scores(ok)[task]
    # The failed seeds are kept: a rerun runs nothing and changes nothing.
    assert mmq.suite.evaluate(Raises, out=tmp_path / "o", name="raises", suite=_tiny(tmp_path)) == r


def test_a_bad_action_fails_its_seed_only(tmp_path):
    class Bad(BatchQ):
        steps = 0

        def act_batch(self, states):
            a = super().act_batch(states)
            self.steps += 1
            if self.steps > 50:
                a[1] = 99
            return a

    kw = dict(suite=_tiny(tmp_path), tasks=["five-poisson2"])
    r = mmq.suite.evaluate(Bad, out=tmp_path / "bad", name="q", **kw)
    _validate(r)
    seeds = _scores(r)["five-poisson2"]
    assert seeds[1]["failed"] and "returned 99 for seed 1 (index 1); the actions are 0..3" in seeds[1]["error"]
    good = _scores(mmq.suite.evaluate(BatchQ, out=tmp_path / "good", name="q", **kw))["five-poisson2"]
    assert [seeds[i] for i in (0, 2, 3)] == [good[i] for i in (0, 2, 3)]


@pytest.mark.parametrize(
    "answer, says",
    [
        (lambda n: [0] * (n + 1), "5 values; give one int action per seed (4)"),
        (lambda n: None, "no sequence; give one int action per seed"),
        (lambda n: np.zeros(n), "returned np.float64(0.0) (float64) for seed 0 (index 0), not an int action"),
        (lambda n: [True] * n, "returned True (bool) for seed 0 (index 0), not an int action"),
    ],
)
def test_answers_that_are_not_actions_fail_their_seeds(tmp_path, answer, says):
    class Odd:
        def __init__(self, task):
            self.n = len(task.seeds)

        def act_batch(self, states):
            return answer(self.n)

        def observe_batch(self, *a):
            pass

    r = mmq.suite.evaluate(Odd, out=tmp_path / "o", name="odd", suite=_tiny(tmp_path), tasks=["five-poisson2"])
    seeds = _scores(r)["five-poisson2"]
    assert len(seeds) == 4 and seeds[0]["failed"] and says in seeds[0]["error"], seeds
    assert all(s["failed"] for s in seeds), seeds


def test_the_arrays_a_batched_agent_gets(tmp_path):
    seen = {}

    class Looks:
        def __init__(self, task):
            self.n = len(task.seeds)

        def act_batch(self, states):
            seen.setdefault("states", (states.dtype, states.shape, states.flags.writeable))
            return np.zeros(self.n, dtype=np.int64)

        def observe_batch(self, states, actions, rewards, next_states, infos):
            if "observe" not in seen:
                seen["observe"] = [(a.dtype, a.shape) for a in (actions, rewards, next_states, infos["t"], infos["time_s"])]
                seen["t"] = infos["t"].tolist()

    r = mmq.suite.evaluate(Looks, out=tmp_path / "o", name="looks", suite=_tiny(tmp_path), tasks=["three-uniform"])
    _validate(r)
    assert seen["states"] == (np.dtype(np.int64), (3,), False)
    i, f = np.dtype(np.int64), np.dtype(np.float64)
    assert seen["observe"] == [(i, (3,)), (f, (3,)), (i, (3,)), (i, (3,)), (f, (3,))]
    assert seen["t"] == [0, 0, 0]
    # Without greedy_batch, act_batch is the greedy policy.
    assert all(s["greedy_fraction_of_optimum"] is not None for s in r["tasks"][0]["seeds"])


def test_an_interrupted_batch_is_run_again_on_resume(tmp_path):
    suite = _tiny(tmp_path)
    whole = mmq.suite.evaluate(BatchQ, out=tmp_path / "whole", name="q", suite=suite)

    class Interrupts(BatchQ):
        def observe_batch(self, states, actions, rewards, next_states, infos):
            if len(self.seeds) == 3 and infos["t"][0] == 500:  # three-uniform, the second task
                raise KeyboardInterrupt
            super().observe_batch(states, actions, rewards, next_states, infos)

    with pytest.raises(KeyboardInterrupt):
        mmq.suite.evaluate(Interrupts, out=tmp_path / "cut", name="q", suite=suite)
    cut = json.loads((tmp_path / "cut/results.json").read_text())
    assert cut["complete"] is False
    assert sum(len(t["seeds"]) for t in cut["tasks"]) == 4  # the first task's batch
    made = []

    def counted(task):
        made.append((task.name, task.seeds))
        return BatchQ(task)

    resumed = mmq.suite.evaluate(counted, out=tmp_path / "cut", name="q", suite=suite)
    assert made == [("three-uniform", (0, 1, 2)), ("robot-five", (0, 1))]
    assert resumed["tasks"] == whole["tasks"] and resumed["complete"]


def test_a_batch_over_its_time_limit_fails(tmp_path):
    import time

    class Slow(BatchQ):
        def act_batch(self, states):
            time.sleep(0.002)
            return super().act_batch(states)

    r = mmq.suite.evaluate(
        Slow, out=tmp_path / "o", name="slow", suite=_tiny(tmp_path), tasks=["three-uniform"], time_limit_s=0.05
    )
    seeds = _scores(r)["three-uniform"]
    assert len(seeds) == 3 and all(s["failed"] and "ran out of time" in s["error"] for s in seeds), seeds


def test_a_batched_agent_whose_first_making_raises(tmp_path):
    """Whether the agent is batched is seen on the first agent made: if making it raises,
    the evaluation drives agents of one seed, and a batched agent's seeds fail saying so."""
    calls = []

    def make(task):
        calls.append(task.seeds)
        if len(calls) == 1:
            raise RuntimeError("cannot make it")
        return BatchQ(task)

    r = mmq.suite.evaluate(make, out=tmp_path / "o", name="q", suite=_tiny(tmp_path), tasks=["three-uniform"])
    _validate(r)
    seeds = _scores(r)["three-uniform"]
    assert "RuntimeError: cannot make it" in seeds[0]["error"]
    assert all("it has act_batch, but this evaluation drives agents of one seed" in s["error"] for s in seeds[1:])
    assert calls == [(0, 1, 2), (1,), (2,)]
