"""mmq: reinforcement learning when rewards arrive late.

``import mmq`` registers the Gymnasium environments ``mmq/Grid-v0`` (the paper's grid
world) and ``mmq/Robot-v0`` (a rapier2d differential-drive robot in the same world),
each with a vector form batched in Rust (``gym.make_vec(...,
vectorization_mode="vector_entry_point")``). It also gives the learners of mmq
(:class:`Learner`), the CLI's runner (:func:`run`) and readers for run folders
(:func:`read_run`) and MCAP recordings (:func:`read_recording`), and runs agents of
your own on the benchmark suite (:func:`mmq.suite.evaluate`).

Example::

    import gymnasium as gym, mmq
    env = gym.make("mmq/Grid-v0", world="paper-9x9", delay="poisson:13")
    obs, info = env.reset(seed=0)
    obs, reward, terminated, truncated, info = env.step(env.action_space.sample())
"""

from __future__ import annotations

import gymnasium as gym

from mmq import _mmq, suite
from mmq._mmq import ConfigError, next_seed
from mmq.learn import Learner, run
from mmq.read import Recording, Run, read_recording, read_run

__all__ = [
    "ConfigError",
    "Learner",
    "Recording",
    "Run",
    "learners",
    "next_seed",
    "optimum",
    "read_recording",
    "read_run",
    "run",
    "suite",
    "world_names",
]

__version__ = _mmq.__version__

ConfigError.__module__ = "mmq"


def world_names() -> list[str]:
    """The worlds shipped with the package (pass one as ``world=``)."""
    return list(_mmq.world_names())


def learners() -> dict[str, str]:
    """Learner names and their one-line descriptions."""
    return dict(_mmq.learners())


def optimum(world: str = "paper-9x9") -> dict:
    """The exact optimum of a world under the paper's dynamics: ``gain`` (the optimal
    average reward per step; 10/17 on paper-9x9), ``actions`` (per cell, the set of
    optimal action indices) and ``free`` (per cell, whether it is free)."""
    gain, bits, free = _mmq.optimum(str(world))
    return {
        "gain": gain,
        "actions": [{a for a in range(8) if b & (1 << a)} for b in bits],
        "free": list(free),
    }


def _register() -> None:
    for name, kind, steps in (("Grid", "Grid", 1000), ("Robot", "Robot", 200)):
        env_id = f"mmq/{name}-v0"
        if env_id in gym.registry:
            continue
        gym.register(
            id=env_id,
            entry_point=f"mmq.envs:{kind}Env",
            vector_entry_point=f"mmq.vector:{kind}VectorEnv",
            max_episode_steps=steps,
        )


_register()
