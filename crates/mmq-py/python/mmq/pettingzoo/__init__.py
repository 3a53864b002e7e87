"""PettingZoo environments of mmq (needs ``pip install pettingzoo``).

``swarm_v0``: several rapier2d robots in one arena, deciding asynchronously, each
reward reaching its robot when a radio consultation completes::

    from mmq.pettingzoo import swarm_v0
    env = swarm_v0.parallel_env(world="paper-9x9", robots=4, consult="peers")

See docs/python.md, "PettingZoo: the robot swarm".
"""

from __future__ import annotations

from mmq.pettingzoo import swarm_v0

__all__ = ["swarm_v0"]
