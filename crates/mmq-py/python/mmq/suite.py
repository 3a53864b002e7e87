"""The benchmark suite for Python agents (docs/suite.md, "Python agents").

:func:`evaluate` runs an agent of yours on every task and seed of a tier of the suite,
through the same engine and store as ``mmq suite run``, and writes the same
``results.json``, ready for ``mmq suite report`` beside the built-in learners.

Example::

    import numpy as np, mmq

    class Q:
        def __init__(self, task):
            self.q = np.full((task.n_states, task.n_actions), task.q0)
            self.eps, self.rng = task.epsilon, np.random.default_rng(task.seed)
        def act(self, state):
            if self.rng.random() < self.eps:
                return int(self.rng.integers(len(self.q[state])))
            best = np.flatnonzero(self.q[state] == self.q[state].max())
            return int(self.rng.choice(best))
        def observe(self, state, action, reward, next_state, info):
            target = reward + 0.9 * self.q[next_state].max()
            self.q[state, action] += 0.1 * (target - self.q[state, action])

    results = mmq.suite.evaluate(Q, tier="lite", out="suite/my-q", name="my-q")

An agent with ``act_batch`` and ``observe_batch`` plays all the seeds of a task at once
(docs/suite.md, "Batched agents")."""

from __future__ import annotations

import json
import os
from dataclasses import dataclass
from typing import Any, Callable, Optional, Sequence, Tuple

from mmq import _mmq

__all__ = ["Task", "evaluate"]


@dataclass(frozen=True)
class Task:
    """What an agent is told about the seeds of one task it is made for.

    ``name``: the task's name; ``n_states``, ``n_actions``: the table's shape (states
    are ``0..n_states``, actions ``0..n_actions``); ``seed``: the master seed (seed your
    own randomness with it); ``seeds``: the master seeds of a batched agent, in the order
    of its arrays (``seed`` is the first; an agent of one seed plays ``seed`` only);
    ``max_delay``: delays stay below it (``None`` if the task gives none). ``epsilon``
    and ``q0`` are the task's exploration rate and initial value for an ε-greedy tabular
    agent: the protocol's suggestion, which the built-in learners follow; exploration is
    the agent's own business."""

    name: str
    n_states: int
    n_actions: int
    seed: int
    max_delay: Optional[int]
    epsilon: float
    q0: float
    seeds: Tuple[int, ...] = ()


def evaluate(
    make_agent: Callable[[Task], Any],
    tier: str = "lite",
    *,
    out: str | os.PathLike,
    name: str = "my-agent",
    suite: str = "v1",
    tasks: Optional[Sequence[str]] = None,
    time_limit_s: Optional[float] = None,
) -> dict:
    """Runs the agent ``make_agent(task)`` returns on every task and seed of ``tier``
    (``"lite"`` or ``"full"``) of ``suite`` (``"v1"`` or a suite file ``*.toml``) and
    writes ``out/results.json``; returns its contents.

    An agent has ``act(state) -> int`` (ε-greedy while learning, say),
    ``observe(state, action, reward, next_state, info)`` (``reward`` is the reward
    delivered at this step, a sum of delayed rewards, often 0; ``info`` holds ``t``, the
    step, and ``time_s``, the simulated time) and, optionally, ``greedy(state) -> int``
    for the final greedy evaluation (without it, ``act`` is used). A new agent is made
    for every seed.

    A batched agent has ``act_batch(states) -> actions``,
    ``observe_batch(states, actions, rewards, next_states, infos)`` and, optionally,
    ``greedy_batch(states) -> actions``: it is made once per task for all its pending
    seeds (``task.seeds``), which step together; the arguments are read-only NumPy
    arrays of one entry per seed (``int64``; ``rewards`` ``float64``; ``infos`` a dict
    of the arrays ``t`` and ``time_s``), reused from call to call (copy what you keep),
    and ``actions`` is one int per seed. Each seed gets the results it would get from
    the same decisions made one seed at a time. An exception of a batched call fails
    every seed of its task's batch; a bad action fails its seed only; the time limit is
    ``time_limit_s`` per seed of the batch; an interrupted batch is run again from its
    start by the next call.

    An exception of the agent (or of ``make_agent``), an action that is not an int or is
    out of range, or a seed over ``time_limit_s`` seconds of wall time fails that seed
    only: it is recorded with the error and the other seeds go on. Finished and failed
    seeds are kept in ``out`` as they end: a second call with the same arguments runs only
    the rest (Ctrl-C stops at once, keeping them, and raises ``KeyboardInterrupt`` after
    writing ``results.json``). ``tasks`` (a list of task names) runs those tasks only; the
    results file then holds only them and says ``"complete": false``. A bad tier, task,
    suite or argument raises :class:`mmq.ConfigError` naming it."""
    if not callable(make_agent):
        raise _mmq.ConfigError("make_agent: give a callable taking a mmq.suite.Task and returning an agent")
    if tasks is not None:
        if isinstance(tasks, str):
            tasks = [tasks]
        tasks = [str(t) for t in tasks]

    def build(**kw: Any) -> Any:
        kw["seeds"] = tuple(kw["seeds"])
        return make_agent(Task(**kw))

    path = _mmq.suite_evaluate(
        build, str(tier), os.fspath(out), str(name), str(suite), tasks, None if time_limit_s is None else float(time_limit_s)
    )
    with open(path, encoding="utf-8") as f:
        return json.load(f)
