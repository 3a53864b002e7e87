"""Gymnasium environments ``mmq/Grid-v0`` and ``mmq/Robot-v0``: the paper's grid world
and the rapier2d differential-drive robot, with every non-zero reward delivered after a
random delay.

See docs/python.md for the spaces, the reward and delay model and the ``info`` keys.
"""

from __future__ import annotations

import math
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from mmq import _mmq

IN_FLIGHT = ("drop", "flush", "carry")
OBSERVATIONS = ("state", "pose")


def _episode_seed(env: gym.Env, seed: int | None, previous: int | None) -> int:
    """The master seed of the next episode: the given one, else the chain from the last
    one (``mmq.next_seed``), else one drawn from the environment's generator."""
    if seed is not None:
        return int(seed)
    if previous is not None:
        return _mmq.next_seed(previous)
    return int(env.np_random.integers(0, 2**63))


class MmqEnv(gym.Env):
    """A world of mmq behind a reward-delay channel, as a Gymnasium environment.

    Args:
        world: a shipped world's name (``mmq.world_names()``, e.g. ``"paper-9x9"``) or the
            path of a world file.
        delay: the delay spec, as the CLI's ``--delay`` (``"none"``, ``"const:13"``,
            ``"poisson:13"``, ``"uniform:0:26"``, ...); delays are in decision steps.
        start: ``"world"`` (the world file's rule: a uniformly random free non-goal cell,
            or ``S``), ``"respawn"`` (always ``S``) or a free cell's state index.
        observation: ``"state"`` (``Discrete(n_states)``) or ``"pose"`` (a ``Dict`` with the
            state, the true pose ``[x m, y m, heading rad]`` and the simulated time).
        in_flight: rewards still in flight when an episode ends: ``"drop"`` (lost at the
            reset), ``"flush"`` (all delivered with the reward of the step that is
            truncated by the time limit) or ``"carry"`` (the channel is not emptied at a
            reset: they arrive in the next episode at their due step).
        preset, profile, overrides: robot only; set ``preset``, ``profile`` and any field
            of the world's ``[robot]`` table (``{"max_speed_mps": 0.15,
            "noise.slip_probability": 0.02}``; dotted keys reach nested tables).
        episode_steps: the env's own episode length: at that step it reports
            ``truncated`` itself (as the ``TimeLimit`` of ``gym.make(...,
            max_episode_steps=N)`` does, which the environment cannot see). Needed by
            ``in_flight="flush"``; ``None``: no limit of its own.
        render_mode: ``None`` or ``"ansi"`` (the map with the agent as ``A``).
    """

    metadata = {"render_modes": ["ansi"], "render_fps": 10}
    _kind = "grid"

    def __init__(
        self,
        world: str = "paper-9x9",
        delay: str = "poisson:13",
        *,
        start: str | int = "world",
        observation: str = "state",
        in_flight: str = "drop",
        preset: str | None = None,
        profile: str | None = None,
        overrides: dict[str, Any] | None = None,
        episode_steps: int | None = None,
        render_mode: str | None = None,
    ):
        if observation not in OBSERVATIONS:
            raise _mmq.ConfigError(
                f"observation: `{observation}` is not accepted; use \"state\" or \"pose\""
            )
        if render_mode not in (None, "ansi"):
            raise _mmq.ConfigError(
                f"render_mode: `{render_mode}` is not accepted; use None or \"ansi\""
            )
        if episode_steps is not None and (
            isinstance(episode_steps, bool) or not isinstance(episode_steps, (int, np.integer))
            or episode_steps < 1
        ):
            raise _mmq.ConfigError(
                f"episode_steps: {episode_steps!r} is not accepted; use a positive number of steps or None"
            )
        if in_flight == "flush" and episode_steps is None:
            raise _mmq.ConfigError(
                "in_flight: \"flush\" delivers the rewards in flight at the step that ends the "
                "episode, which the environment must know: pass episode_steps=N (the time "
                "limit, as gym.make's max_episode_steps=N)"
            )
        self.episode_steps = None if episode_steps is None else int(episode_steps)
        self._core = _mmq.EnvCore(
            self._kind, str(world), str(delay), start, in_flight, preset, profile, overrides
        )
        self.world = str(world)
        self.delay = self._core.delay
        self.in_flight = in_flight
        self.observation = observation
        self.render_mode = render_mode
        n = self._core.n_states
        self.action_space = spaces.Discrete(self._core.n_actions)
        name, width, height, cell, goal, respawn = self._core.world_facts
        self.world_name, self.width, self.height, self.cell_size = name, width, height, cell
        self.goal, self.respawn = goal, respawn
        if observation == "state":
            self.observation_space = spaces.Discrete(n)
        else:
            lo = np.array([0.0, 0.0, -math.pi])
            hi = np.array([width * cell, height * cell, math.pi])
            self.observation_space = spaces.Dict(
                {
                    "state": spaces.Discrete(n),
                    "pose": spaces.Box(lo, hi, dtype=np.float64),
                    "time": spaces.Box(0.0, 1e15, shape=(1,), dtype=np.float64),
                }
            )
        self._seed: int | None = None
        self._state = 0
        self._elapsed = 0

    # -- helpers -----------------------------------------------------------------------

    def _obs(self, state: int):
        if self.observation == "state":
            return state
        x, y, theta, _ = self._core.pose()
        w, h = self.width * self.cell_size, self.height * self.cell_size
        pose = np.array(
            [min(max(x, 0.0), w), min(max(y, 0.0), h), math.remainder(theta, 2 * math.pi)]
        )
        return {"state": state, "pose": pose, "time": np.array([self._core.time_s])}

    # -- Gymnasium API -----------------------------------------------------------------

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        """Starts an episode. ``seed`` is the master seed of the CLI's ``--seed``: the
        same seed gives the same start and the same delays as ``mmq run``. Without a
        seed, the next seed in the chain ``mmq.next_seed`` is used."""
        super().reset(seed=seed)
        self._seed = _episode_seed(self, seed, self._seed)
        self._state = self._core.reset(self._seed)
        self._elapsed = 0
        info = {
            # A NumPy uint64: seeds span 0..2**64, which a vector environment's int64
            # info array would not hold.
            "seed": np.uint64(self._seed),
            "t": self._core.t,
            "sim_time_s": self._core.time_s,
            "in_flight": self._core.in_flight(),
        }
        return self._obs(self._state), info

    def step(self, action):
        s, delivered, emitted, delay, event, t, time_s, deliveries, true_state = self._core.step(
            action
        )
        self._state = s
        self._elapsed += 1
        info: dict[str, Any] = {
            "emitted": emitted,
            "delay_steps": delay,  # -1: nothing emitted (or a delay in seconds)
            "deliveries": [
                {"t_emit": te, "delay_steps": d, "delay_s": ds, "value": v}
                for te, d, ds, v in deliveries
            ],
            "t": t,
            "sim_time_s": time_s,
            "event": event,
        }
        if true_state is not None:
            info["true_state"] = true_state
            info["believed_state"] = s
        reward = delivered
        limit = self.episode_steps
        truncated = limit is not None and self._elapsed >= limit
        if truncated and self.in_flight == "flush":
            flushed = self._core.pending()
            info["flushed"] = [
                {"t_emit": te, "delay_steps": d, "delay_s": ds, "value": v}
                for te, d, ds, v in flushed
            ]
            reward += self._core.in_flight()
        info["in_flight"] = self._core.in_flight()
        return self._obs(s), float(reward), False, truncated, info

    def render(self):
        if self.render_mode != "ansi":
            return None
        rows = [list(r) for r in self._core.ascii.splitlines()]
        r, c = divmod(self._state, self.width)
        rows[r][c] = "A"
        return "\n".join("".join(r) for r in rows) + "\n"

    # -- extras --------------------------------------------------------------------------

    def step_fast(self, action: int) -> tuple[int, float]:
        """One step without ``info``: (next state, delivered reward). The time limit and
        ``in_flight="flush"`` are not applied."""
        s, r = self._core.step_fast(action)
        self._state = s
        self._elapsed += 1
        return s, r

    @property
    def action_names(self) -> list[str]:
        """Action names in index order (N, E, S, W)."""
        return self._core.action_names

    def totals(self) -> tuple[float, float]:
        """(emitted, delivered) totals since the channel was last emptied."""
        return self._core.totals()

    def pose_estimate(self):
        """The robot's own pose estimate ``(x, y, heading, time)`` where it controls on an
        estimate, else ``None``."""
        return self._core.pose_estimate()

    def stats(self) -> dict[str, float]:
        """Environment counters (robot physics)."""
        return dict(self._core.stats())


class GridEnv(MmqEnv):
    """``mmq/Grid-v0``: the paper's grid world (one move per step)."""

    _kind = "grid"


class RobotEnv(MmqEnv):
    """``mmq/Robot-v0``: the rapier2d differential-drive robot; an action is a motion
    primitive to a neighbouring cell."""

    _kind = "robot"
