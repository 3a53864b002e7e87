"""Learners of mmq driven from Python, and runs of the lab's runner (``mmq run``)."""

from __future__ import annotations

import json
from typing import Any

import numpy as np

from mmq import _mmq


class Learner:
    """A learner of mmq (``mmq.learners()`` lists them), stepped from Python.

    ``mmq.Learner("mmq", n_states, n_actions, seed=0, max_delay=50, epsilon=0.01)``

    Args:
        name: the learner's name as on the command line (``q``, ``fixed``, ``mmq``, ...).
        n_states, n_actions: table sizes.
        seed: the master seed; exploration draws from its exploration stream and greedy
            ties from its evaluation stream, as ``mmq run --seed`` does, so the same
            steps give the same tables as the CLI.
        **settings: hyper-parameters by their config names: the shared ``alpha``,
            ``gamma``, ``epsilon``, ``q0``, and the learner's own settings (``max_delay``
            of ``mmq``, ``lambda_hat`` of ``fixed``, ``trace_decay`` of ``q-lambda``, ...);
            one the learner does not have raises ``ConfigError``.

    The learner sees only (s, a, delivered reward, s'); call :meth:`observe` once per
    step, in order.
    """

    def __init__(self, name: str, n_states: int, n_actions: int, *, seed: int = 0, **settings):
        self._core = _mmq.LearnerCore(str(name), int(n_states), int(n_actions), seed, settings)
        self.n_states, self.n_actions = int(n_states), int(n_actions)

    @property
    def name(self) -> str:
        """The learner's name."""
        return self._core.name

    @property
    def steps(self) -> int:
        """Steps observed so far."""
        return self._core.steps

    def act(self, state: int) -> int:
        """The ε-greedy action in ``state`` (ties at random)."""
        return self._core.act(state)[0]

    def decide(self, state: int) -> tuple[int, int | None, bool]:
        """As :meth:`act`, with the delay model acted on (MMQ's λ̂*, or ``None``) and
        whether the action was exploratory."""
        return self._core.act(state)

    def observe(
        self, state: int, action: int, reward: float, next_state: int, time_s: float | None = None
    ) -> None:
        """Learns from one step: ``reward`` is the reward delivered at this step, ``time_s``
        the simulated time at its end (``info["sim_time_s"]``; the time-aware learners need
        it, the others ignore it; default: the step count × 0.1 s)."""
        self._core.observe(
            int(state), int(action), float(reward), int(next_state), None if time_s is None else float(time_s)
        )

    def greedy(self, state: int) -> int:
        """The greedy action (no exploration; ties from the evaluation stream)."""
        return self._core.greedy(int(state))

    def action_values(self, state: int) -> np.ndarray:
        """The action values the policy acts on in ``state`` (MMQ: its best model's)."""
        return self._core.action_values(int(state))

    def tables(self) -> dict[str, np.ndarray]:
        """The learner's tables by name, shaped as the CLI's ``.npy`` files
        (MMQ's ``q``: states × models × actions)."""
        return {name: data.reshape(shape) for name, shape, data in self._core.tables()}

    @property
    def q(self) -> np.ndarray:
        """The ``q`` table."""
        return self.tables()["q"]

    def metrics(self) -> dict[str, float]:
        """Learner-specific figures (e.g. a delay estimate)."""
        return dict(self._core.metrics())

    def __repr__(self) -> str:
        return f"Learner({self.name!r}, {self.n_states}, {self.n_actions}, steps={self.steps})"


def run(
    world: str = "paper-9x9",
    *,
    env: str = "grid",
    learner: str = "mmq",
    delay: str = "poisson:13",
    steps: int = 150_000,
    seeds: int = 1,
    seed: int = 0,
    window: int = 1000,
    eval_steps: int = 1000,
    baseline: bool = True,
    save_tables: bool = True,
    out: str | None = None,
    record: bool = False,
    preset: str | None = None,
    profile: str | None = None,
    overrides: dict[str, Any] | None = None,
    **settings,
) -> dict[str, Any]:
    """Runs the lab's runner exactly as ``mmq run`` does and returns its summary.

    Arguments mirror the CLI's flags (``--world``, ``--env``, ``--learner``, ``--delay``,
    ``--steps``, ``--seeds``, ``--seed``, ``--window``, ``--eval-steps``,
    ``--no-baseline``, ``--no-tables``, ``--out``, ``--record``, ``--robot``); learner
    hyper-parameters go in ``**settings`` as for :class:`Learner`. With ``out``, the
    run's files (config.toml, summary.json, metrics.csv, policy.csv, ``*.npy``, MCAP
    recordings) are written there as the CLI writes them; read them with
    :func:`mmq.read_run`.
    """
    for name, value in (("steps", steps), ("seeds", seeds), ("window", window),
                        ("eval_steps", eval_steps)):
        if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 0:
            raise _mmq.ConfigError(
                f"{name}: {value!r} is not accepted; use a whole number ≥ 0 (see mmq run --help)"
            )
    text = _mmq.run_json(
        str(world),
        env,
        learner,
        delay,
        int(steps),
        int(seeds),
        seed,
        int(window),
        int(eval_steps),
        bool(baseline),
        bool(save_tables),
        None if out is None else str(out),
        bool(record),
        preset,
        profile,
        overrides,
        settings,
    )
    return json.loads(text)
