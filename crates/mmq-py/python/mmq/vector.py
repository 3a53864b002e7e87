"""Vector environments batched in Rust: ``gym.make_vec("mmq/Grid-v0", num_envs=N,
vectorization_mode="vector_entry_point")``.

One call steps all N environments with the GIL released (robots on threads). Episodes
are cut at ``max_episode_steps`` and reset on the next step (Gymnasium's next-step
autoreset), so environment i behaves exactly as a single environment reset with seed
``seed + i`` and then without a seed after every truncation.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from gymnasium import spaces
from gymnasium.vector import AutoresetMode, VectorEnv

from mmq import _mmq


class MmqVectorEnv(VectorEnv):
    """N environments of one world, delay and robot configuration.

    Args are those of :class:`mmq.envs.MmqEnv` (observations are states only), plus
    ``num_envs``, ``max_episode_steps`` (``None``: never truncated; ``episode_steps``
    is accepted as its synonym) and ``threads``
    (step the environments on threads; default: for robots only).

    ``step`` returns NumPy arrays; ``info`` holds ``"emitted"``, the rewards emitted this
    step (before their delays).
    """

    metadata = {"autoreset_mode": AutoresetMode.NEXT_STEP, "render_modes": []}
    _kind = "grid"

    def __init__(
        self,
        num_envs: int = 1,
        world: str = "paper-9x9",
        delay: str = "poisson:13",
        *,
        start: str | int = "world",
        observation: str = "state",
        in_flight: str = "drop",
        max_episode_steps: int | None = None,
        preset: str | None = None,
        profile: str | None = None,
        overrides: dict[str, Any] | None = None,
        threads: bool | None = None,
        episode_steps: int | None = None,
        render_mode: str | None = None,
    ):
        if observation != "state":
            raise _mmq.ConfigError(
                "observation: vector environments observe states only; use observation=\"state\" "
                "or single environments for poses"
            )
        if render_mode is not None:
            raise _mmq.ConfigError("render_mode: vector environments do not render; use None")
        if max_episode_steps is None:
            max_episode_steps = episode_steps
        elif episode_steps is not None and episode_steps != max_episode_steps:
            raise _mmq.ConfigError(
                f"episode_steps: {episode_steps} differs from max_episode_steps = "
                f"{max_episode_steps}; give one of them"
            )
        self._core = _mmq.VecCore(
            self._kind,
            str(world),
            str(delay),
            start,
            in_flight,
            int(num_envs),
            max_episode_steps,
            preset,
            profile,
            overrides,
            threads,
        )
        self.num_envs = self._core.num_envs
        self.render_mode = None
        self.max_episode_steps = max_episode_steps
        self.single_observation_space = spaces.Discrete(self._core.n_states)
        self.single_action_space = spaces.Discrete(self._core.n_actions)
        self.observation_space = spaces.MultiDiscrete(
            np.full(self.num_envs, self._core.n_states, dtype=np.int64)
        )
        self.action_space = spaces.MultiDiscrete(
            np.full(self.num_envs, self._core.n_actions, dtype=np.int64)
        )
        self._seeds: list[int] | None = None
        self._terminated = np.zeros(self.num_envs, dtype=bool)

    def reset(self, *, seed: int | list[int] | None = None, options: dict | None = None):
        """Resets every environment: ``seed`` an int gives ``seed + i`` to environment i
        (as Gymnasium's vector environments do), a list gives one seed each, ``None``
        continues each environment's seed chain."""
        super().reset(seed=seed if isinstance(seed, int) or seed is None else None)
        n = self.num_envs
        if seed is None:
            if self._seeds is None:
                seeds = [int(self.np_random.integers(0, 2**63)) for _ in range(n)]
            else:
                seeds = [_mmq.next_seed(s) for s in self._core.seeds]
        elif isinstance(seed, (int, np.integer)):
            seeds = [int(seed) + i for i in range(n)]
        else:
            seeds = [int(s) for s in seed]
            if len(seeds) != n:
                raise _mmq.ConfigError(f"seed: {len(seeds)} seeds for {n} environments")
        self._seeds = seeds
        obs = self._core.reset(seeds)
        return obs, {}

    def step(self, actions):
        """Steps all environments: (states, delivered rewards, terminated (always
        False), truncated, info with ``"emitted"``)."""
        acts = np.ascontiguousarray(actions, dtype=np.int64)
        obs, rewards, truncated, emitted = self._core.step(acts)
        return obs, rewards, self._terminated.copy(), truncated, {"emitted": emitted}

    def random_steps(self, steps: int, seed: int = 0) -> float:
        """Steps every environment ``steps`` times with uniformly random actions drawn in
        Rust (a benchmark with no Python in the loop); returns the reward delivered."""
        return self._core.random_steps(int(steps), int(seed))


class GridVectorEnv(MmqVectorEnv):
    """Vector form of ``mmq/Grid-v0``."""

    _kind = "grid"


class RobotVectorEnv(MmqVectorEnv):
    """Vector form of ``mmq/Robot-v0`` (environments stepped on threads)."""

    _kind = "robot"
