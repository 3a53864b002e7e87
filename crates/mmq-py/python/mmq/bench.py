"""Speed of the Python bindings: ``python -m mmq.bench [--quick] [--only grid,vector,robot]``.

Measures, on the 9×9 paper world with uniformly random actions:

- ``grid raw``: one grid step through the native core (``env.unwrapped.step_fast``), with
  no ``info`` and no wrapper;
- ``grid env.step``: one step of the bare environment with its full ``info``;
- ``grid gym.make``: one step through ``gym.make`` (TimeLimit, order enforcing and the
  passive checker wrappers);
- ``vector N``: grid steps per second of ``gym.make_vec(..., vectorization_mode=
  "vector_entry_point")`` stepped from Python with a NumPy action array, N = 1…64, and
  the same batch stepped in Rust alone (``random_steps``);
- ``robot``: primitives per second of one robot stepped from Python, to compare with
  ``cargo bench -p mmq-robot --bench primitives`` (group ``robot``), and of the robot
  vector environment on threads.

Every figure is the best of a few repetitions. Single-threaded figures are in CPU time
of this process (``time.process_time``), which a busy shared machine inflates far less
than wall time; the threaded robot vector is in wall time.
"""

from __future__ import annotations

import argparse
import time

import gymnasium as gym
import numpy as np

import mmq  # noqa: F401  (registers the environments)


def _best(fn, reps: int, clock=time.process_time) -> float:
    best = float("inf")
    for _ in range(reps):
        t0 = clock()
        fn()
        best = min(best, clock() - t0)
    return best


def grid(n: int, reps: int) -> dict[str, float]:
    out = {}
    rng = np.random.default_rng(0)
    actions = rng.integers(0, 4, size=n).tolist()

    env = gym.make("mmq/Grid-v0", world="paper-9x9", delay="poisson:13", max_episode_steps=10**12)
    env.reset(seed=0)
    raw = env.unwrapped.step_fast

    def run_raw():
        for a in actions:
            raw(a)

    out["grid raw step (µs)"] = _best(run_raw, reps) / n * 1e6

    bare = env.unwrapped
    bstep = bare.step

    def run_bare():
        for a in actions:
            bstep(a)

    out["grid env.step with info (µs)"] = _best(run_bare, reps) / n * 1e6

    step = env.step

    def run_made():
        for a in actions:
            step(a)

    out["grid gym.make step (µs)"] = _best(run_made, reps) / n * 1e6
    env.close()
    return out


def vector(n_envs: list[int], calls: int, reps: int) -> dict[str, float]:
    out = {}
    for n in n_envs:
        venv = gym.make_vec(
            "mmq/Grid-v0",
            num_envs=n,
            vectorization_mode="vector_entry_point",
            world="paper-9x9",
            delay="poisson:13",
        )
        venv.reset(seed=0)
        acts = np.random.default_rng(n).integers(0, 4, size=(calls, n), dtype=np.int64)
        step = venv.step

        def run():
            for a in acts:
                step(a)

        t = _best(run, reps)
        out[f"vector N={n} from Python (M steps/s)"] = n * calls / t / 1e6
        inner = venv.unwrapped
        per = max(1, calls * 64 // n)
        t = _best(lambda: inner.random_steps(per, 1), reps)
        out[f"vector N={n} in Rust (M steps/s)"] = n * per / t / 1e6
        venv.close()
    return out


def robot(primitives: int, reps: int) -> dict[str, float]:
    out = {}
    env = gym.make("mmq/Robot-v0", world="paper-9x9", delay="none", max_episode_steps=10**12)
    env.reset(seed=1)
    raw = env.unwrapped.step_fast
    actions = np.random.default_rng(2).integers(0, 4, size=primitives).tolist()

    def run():
        for a in actions:
            raw(a)

    out["robot primitives/s, one env from Python"] = primitives / _best(run, reps)
    for n in (2, 8):
        venv = gym.make_vec(
            "mmq/Robot-v0",
            num_envs=n,
            vectorization_mode="vector_entry_point",
            world="paper-9x9",
            delay="none",
        )
        venv.reset(seed=1)
        per = max(1, primitives // n)
        acts = np.random.default_rng(3).integers(0, 4, size=(per, n), dtype=np.int64)
        step = venv.step

        def vrun():
            for a in acts:
                step(a)

        wall = _best(vrun, reps, time.perf_counter)
        out[f"robot primitives/s, vector N={n} on threads (wall)"] = n * per / wall
        venv.close()
    return out


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(prog="python -m mmq.bench", description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="short runs (a smoke test)")
    ap.add_argument("--only", default="grid,vector,robot", help="comma-separated: grid, vector, robot")
    a = ap.parse_args(argv)
    parts = set(a.only.split(","))
    reps = 2 if a.quick else 5
    results: dict[str, float] = {}
    if "grid" in parts:
        results.update(grid(20_000 if a.quick else 300_000, reps))
    if "vector" in parts:
        results.update(vector([1, 2, 4, 8, 16, 32, 64], 500 if a.quick else 20_000, reps))
    if "robot" in parts:
        results.update(robot(200 if a.quick else 3000, 2 if a.quick else 3))
    width = max(len(k) for k in results)
    for k, v in results.items():
        print(f"{k:<{width}}  {v:,.3f}")


if __name__ == "__main__":
    main()
