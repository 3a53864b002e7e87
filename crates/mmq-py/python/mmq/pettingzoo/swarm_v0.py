"""``mmq_swarm_v0``: a swarm of rapier2d differential-drive robots in one world of mmq,
as a PettingZoo ``ParallelEnv`` with asynchronous decisions and rewards delayed by a
radio consultation.

See :class:`SwarmEnv` for the conventions and docs/python.md for the details.
"""

from __future__ import annotations

from typing import Any

import numpy as np

try:
    from pettingzoo import ParallelEnv
except ImportError as e:  # pragma: no cover - depends on the installation
    raise ImportError(
        "mmq.pettingzoo needs PettingZoo: pip install \"pettingzoo>=1.25,<2\""
    ) from e

from gymnasium import spaces

from mmq import _mmq

__all__ = ["Flags", "SwarmEnv", "parallel_env", "robot_seed"]


def parallel_env(**kwargs: Any) -> SwarmEnv:
    """The swarm as a PettingZoo ``ParallelEnv``; the arguments are :class:`SwarmEnv`'s."""
    return SwarmEnv(**kwargs)


def robot_seed(seed: int, i: int) -> int:
    """The seed of robot ``i``'s learner in the CLI's swarm run of master seed ``seed``
    (robot 0's is ``seed`` itself): ``mmq.Learner(..., seed=robot_seed(seed, i))``
    explores as the CLI's learner of robot i does."""
    if i == 0:
        return int(seed)
    return _mmq.next_seed(int(seed) ^ _mmq.next_seed(0x5377_6172_6D00_0000 ^ int(i)))


def _agent_char(i: int) -> str:
    return "0123456789abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ*"[min(i, 62)]


class Flags(dict):
    """``terminations`` or ``truncations`` of a step: keyed by the robots whose primitive
    ended; looking up a live robot that is still moving (absent from the step) reads
    ``False`` instead of raising ``KeyError``. Any other missing key raises."""

    def __init__(self, moving: frozenset = frozenset()):
        super().__init__()
        self.moving = moving

    def __missing__(self, agent):
        if agent in self.moving:
            return False
        raise KeyError(agent)

    def __reduce__(self):
        return (Flags, (self.moving,), None, None, iter(self.items()))


class SwarmEnv(ParallelEnv):
    """Several robots (``robot_0`` … ``robot_{N-1}``) in one rapier2d arena built from a
    world of mmq. Each robot has the single robot's dynamics (``mmq/Robot-v0``): its
    observation is its cell (``Discrete(num_states)``) and an action is a motion
    primitive (``Discrete(num_actions)``). A robot that bumps into another backs off as
    from a wall and earns ``bump_penalty``.

    **Asynchronous decisions: absent robots.** Primitives take different amounts of
    simulated time, so the robots do not decide together. ``reset`` returns every robot
    (all wait for an action). ``step(actions)`` starts the primitives of the robots that
    were waiting (those returned by the previous call), runs the shared physics until at
    least one primitive ends, and returns five dictionaries keyed by **only the robots
    whose primitive ended**: a robot still moving is absent from all of them, and those
    returned are exactly the robots that wait for an action in the next ``step``.
    ``actions`` must hold an action for each of them (one truncated excepted); an action
    for a robot that is not waiting (still moving, or truncated) is ignored. ``agents``
    is the list of robots not yet truncated, moving or not.

    One addition makes PettingZoo's own tools work with absent robots: PettingZoo's API
    test reads ``terminations[agent]`` and ``truncations[agent]`` for *every* live
    agent. So these two are :class:`Flags`, dictionaries whose keys are the robots that
    ended but in which looking up a live robot that is still moving reads ``False`` (it
    is neither terminated nor truncated) instead of raising ``KeyError``; iteration,
    ``len``, ``in`` and ``.get`` see only the robots that ended.

    **Rewards.** The reward of a robot is the reward *delivered* to it at this decision:
    every non-zero reward a robot earns starts a consultation over the radio
    (``consult``: ``"none"``, at once; ``"peers"``, when ``k`` peers in radio range,
    relayed over a unit-disk network, have replied; ``"server"``, when a base station
    has replied), and is delivered at the robot's first decision that ends at or after
    the consultation completed (several may arrive together). A consultation that can
    never complete loses its reward (``info["lost"]``).

    **Episode end.** The task is continuing: no termination. A robot is truncated with
    its ``max_steps``-th decision, parked (it stands still and takes no more actions)
    and removed from ``agents``; when every robot is done, ``agents`` is empty. Its
    rewards still in flight are never delivered (its last ``info["in_flight"]``).

    **Information.** ``infos[agent]`` of ``step`` (each key one type on every step):
    ``decision`` (int, the robot's decision that ended, from 0), ``emitted`` (float, the
    reward earned at it, before consultation), ``event`` (``"moved"``, ``"wall"``,
    ``"goal"``, ``"timeout"``), ``sim_time_s`` (float, the swarm's simulated time),
    ``deliveries`` (list of ``{"decision", "value", "emitted_s", "delay_s", "hops"}``:
    the rewards delivered now, their consultation's delay in simulated seconds and the
    reply's hops), ``consult_delay_s`` (float) and ``consult_hops`` (int) of the earned
    reward's consultation, **-1** when there is none (a zero reward, or a lost one),
    ``lost`` (bool), ``in_flight`` (float: this robot's rewards earned but not
    delivered yet) and, on the realistic profile, ``true_state`` and
    ``believed_state`` (ints: the cell of the true pose and the believed cell, the
    observation). ``reset`` gives every robot ``{"seed", "sim_time_s"}`` (plus
    ``true_state`` and ``believed_state`` on the realistic profile).

    **Seeds.** ``reset(seed=s)`` gives the trajectory of ``mmq run --env swarm --seed
    s`` for the same actions: robot 0 has the seed's own streams (so one robot with
    ``consult="none"`` is ``mmq/Robot-v0`` with ``delay="none"``), the radio the seed's
    delay stream. A reset without a seed follows the chain ``mmq.next_seed``.

    Args:
        world: a shipped world's name (``mmq.world_names()``) or a world file's path.
        robots: the number of robots (1–64).
        consult, k, radio_range_m, hop_delay, loss: the consultation (the fields of a
            world's ``[swarm]`` table, as ``mmq run --swarm``); ``None`` keeps the
            world's value or the default (``none``, ``k=1``, 1.5 m, ``"wifi"``, 0).
        robot: robot settings: a dict of fields of the world's ``[robot]`` table
            (``{"profile": "realistic", "noise.slip_probability": 0.02}``) or a list of
            ``KEY=VALUE`` strings (as the CLI's ``--robot``).
        max_steps: decisions per robot before it is truncated (``None``: never).
        render_mode: ``None`` or ``"ansi"`` (the map with robot i as its index).
        **swarm: any other field of the ``[swarm]`` table: ``starts`` (``"random"`` or
            ``[[row, col], …]``, 1-based), ``server`` (``[row, col]``),
            ``bump_penalty``.
    """

    metadata = {
        "name": "mmq_swarm_v0",
        "render_modes": ["ansi"],
        "render_fps": 10,
        "is_parallelizable": True,
    }

    def __init__(
        self,
        world: str = "paper-9x9",
        robots: int = 4,
        consult: str | None = None,
        k: int | None = None,
        radio_range_m: float | None = None,
        hop_delay: str | None = None,
        loss: float | None = None,
        robot: dict[str, Any] | list[str] | None = None,
        max_steps: int | None = 200,
        render_mode: str | None = None,
        **swarm: Any,
    ):
        if render_mode not in (None, "ansi"):
            raise _mmq.ConfigError(
                f"render_mode: `{render_mode}` is not accepted; use None or \"ansi\""
            )
        if max_steps is not None and (
            isinstance(max_steps, bool)
            or not isinstance(max_steps, (int, np.integer))
            or max_steps < 1
        ):
            raise _mmq.ConfigError(
                f"max_steps: {max_steps!r} is not accepted; "
                "use a positive number of decisions or None"
            )
        fields = {
            "robots": robots,
            "consult": consult,
            "k": k,
            "radio_range_m": radio_range_m,
            "hop_delay": hop_delay,
            "loss": loss,
            **swarm,
        }
        self._core = _mmq.SwarmCore(str(world), robot, fields)
        self.world = str(world)
        self.max_steps = None if max_steps is None else int(max_steps)
        self.render_mode = render_mode
        self.consult = self._core.consult
        n = self._core.robots
        self.possible_agents = [f"robot_{i}" for i in range(n)]
        self._index = {a: i for i, a in enumerate(self.possible_agents)}
        self._observation_spaces = {
            a: spaces.Discrete(self._core.num_states) for a in self.possible_agents
        }
        self._action_spaces = {
            a: spaces.Discrete(self._core.num_actions) for a in self.possible_agents
        }
        self.observation_spaces = self._observation_spaces
        self.action_spaces = self._action_spaces
        name, width, height, cell, goal, respawn = self._core.world_facts
        self.world_name, self.width, self.height, self.cell_size = name, width, height, cell
        self.goal, self.respawn = goal, respawn
        self.agents: list[str] = []
        self._waiting: list[int] = []
        self._decisions = [0] * n
        self._seed: int | None = None

    # -- spaces ------------------------------------------------------------------------

    def observation_space(self, agent: str) -> spaces.Discrete:
        """``Discrete(num_states)``: the robot's cell (the same object on every call)."""
        return self._observation_spaces[agent]

    def action_space(self, agent: str) -> spaces.Discrete:
        """``Discrete(num_actions)``: a motion primitive (the same object on every call)."""
        return self._action_spaces[agent]

    # -- PettingZoo API ----------------------------------------------------------------

    def reset(self, seed: int | None = None, options: dict | None = None):
        """Starts an episode: every robot at its start, waiting for an action. ``seed``
        is the master seed of the CLI's ``--seed``; without one, the next seed in the
        chain ``mmq.next_seed`` (or a random one at the first reset). ``options`` is
        not used."""
        if seed is not None:
            self._seed = int(seed)
        elif self._seed is not None:
            self._seed = _mmq.next_seed(self._seed)
        else:
            self._seed = int(np.random.default_rng().integers(0, 2**63))
        states = self._core.reset(self._seed)
        n = len(self.possible_agents)
        self.agents = self.possible_agents[:]
        self._waiting = list(range(n))
        self._decisions = [0] * n
        truth = self._core.true_states() if self._core.realistic else None
        observations = {a: states[i] for i, a in enumerate(self.agents)}
        infos: dict[str, dict[str, Any]] = {}
        for i, a in enumerate(self.agents):
            info: dict[str, Any] = {"seed": self._seed, "sim_time_s": self._core.time_s}
            if truth is not None:
                info["true_state"] = truth[i]
                info["believed_state"] = states[i]
            infos[a] = info
        return observations, infos

    def step(self, actions: dict[str, Any]):
        """Starts the waiting robots' primitives and returns the robots whose primitive
        ended (see the class docstring)."""
        if not self.agents:
            return {}, {}, {}, {}, {}
        for a in actions:
            if a not in self._index:
                raise ValueError(
                    f"actions: `{a}` is not an agent; the agents are {self.possible_agents}"
                )
        # Every action is checked before any primitive starts.
        for i in self._waiting:
            a = self.possible_agents[i]
            if a not in actions:
                raise ValueError(
                    f"actions: {a} waits for an action (it was returned by the last call); "
                    "give one for every agent of the last observations"
                )
            x = actions[a]
            if isinstance(x, (bool, np.bool_)) or not self._action_spaces[a].contains(x):
                n = self._action_spaces[a].n
                raise ValueError(
                    f"actions: {a}'s action {x!r} is out of range; use an integer in 0..{n}"
                )
        for i in self._waiting:
            self._core.act(i, actions[self.possible_agents[i]])
        rows = self._core.advance()
        in_flight = self._core.in_flight() if rows else []
        observations: dict[str, int] = {}
        rewards: dict[str, float] = {}
        infos: dict[str, dict[str, Any]] = {}
        moving = frozenset(self.agents) - {self.possible_agents[r[0]] for r in rows}
        terminations = Flags(moving)
        truncations = Flags(moving)
        waiting = []
        for (i, decision, state, earned, event, time_s, delivered, deliveries, consultation,
             true_state) in rows:
            a = self.possible_agents[i]
            self._decisions[i] += 1
            observations[a] = state
            rewards[a] = delivered
            info: dict[str, Any] = {
                "decision": decision,
                "emitted": earned,
                "event": event,
                "sim_time_s": time_s,
                "deliveries": [
                    {"decision": d, "value": v, "emitted_s": te, "delay_s": ds, "hops": h}
                    for d, v, te, ds, h in deliveries
                ],
                "consult_delay_s": -1.0 if consultation is None else consultation[0],
                "consult_hops": -1 if consultation is None else consultation[1],
                "lost": earned != 0.0 and consultation is None,
                "in_flight": in_flight[i][1],
            }
            if true_state is not None:
                info["true_state"] = true_state
                info["believed_state"] = state
            infos[a] = info
            terminations[a] = False
            done = self.max_steps is not None and self._decisions[i] >= self.max_steps
            truncations[a] = done
            if done:
                self._core.park(i)
            else:
                waiting.append(i)
        self._waiting = waiting
        self.agents = [a for a in self.agents if not truncations.get(a, False)]
        return observations, rewards, terminations, truncations, infos

    def render(self):
        """``"ansi"``: the map with robot i drawn as its index (0–9, a–z, …) at the cell
        of its true pose."""
        if self.render_mode != "ansi":
            return None
        rows = [list(r) for r in self._core.ascii.splitlines()]
        for i, s in enumerate(self._core.true_states()):
            r, c = divmod(self._core.state_cell(s), self.width)
            rows[r][c] = _agent_char(i)
        return "\n".join("".join(r) for r in rows) + "\n"

    def close(self):
        pass

    # -- extras ------------------------------------------------------------------------

    @property
    def action_names(self) -> list[str]:
        """Action names in index order."""
        return self._core.action_names

    @property
    def sim_time_s(self) -> float:
        """The swarm's simulated time since the reset, seconds."""
        return self._core.time_s

    def poses(self) -> dict[str, tuple[float, float, float, float]]:
        """Every robot's true pose ``(x m, y m, heading rad, simulated time s)``."""
        return dict(zip(self.possible_agents, self._core.poses()))

    def delays(self) -> dict[str, dict[str, Any]]:
        """The delays that emerged since the reset, per robot: ``emitted``,
        ``delivered``, ``lost`` (counts of non-zero rewards), ``delays_s`` and ``hops``
        (every completed consultation, in the order earned)."""
        return {
            a: {"emitted": e, "delivered": d, "lost": lost, "delays_s": list(ds), "hops": list(h)}
            for a, (e, d, lost, ds, h) in zip(self.possible_agents, self._core.delays())
        }

    def in_flight(self) -> dict[str, float]:
        """Per robot, the sum of its rewards earned but not delivered yet."""
        return {a: total for a, (_, total) in zip(self.possible_agents, self._core.in_flight())}

    def stats(self, agent: str) -> dict[str, float]:
        """A robot's counters and diagnostics (as ``mmq/Robot-v0``'s ``stats()``)."""
        return dict(self._core.stats(self._index[agent]))
