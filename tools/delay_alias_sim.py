#!/usr/bin/env python3
"""How well can a delay pmf be estimated from a settled agent's own trajectory?

A diagnostic for docs/algorithms/beyond.md ("Delay estimate"), independent of the Rust
code: the paper's 9x9 world (G top-left, S bottom-right, +10 for any action in G then
back to S, -1 for a wall bump), walked by a *fixed* shortest path (up, then left) with
epsilon-greedy exploration, which is what a converged `deconv-model` does. Rewards go
through a delay channel; the delay pmf over 0..=50 is then fitted by non-negative least
squares **with the true rewards given** (an oracle for everything but the delay), and
the median of the fit is compared with the truth after 50,000 steps.

Usage:  python tools/delay_alias_sim.py [--seeds 10] [--steps 50000] [--epsilon 0.05]
                                        [--delay uniform|poisson13|mixture] [--bic] [--split]

--bic also chooses the pmf's support 0..=m (m = 5..=50) by BIC and reports that fit.
--split also fits the +10 and the -1 deliveries as two separate series (what an agent
could do if it knew which rewards a delivered sum is made of): by non-negative least
squares on both, and by the Poisson maximum likelihood of the delivery counts (EM), and
by the latter on the +10 deliveries alone.
Needs numpy only (tools/.venv from .ci/run has it).
"""

import argparse

import numpy as np

K = 50


def nnls(a, b, iters=500):
    """min ||A x - b||, x >= 0 (Lawson-Hanson active set)."""
    n = a.shape[1]
    x = np.zeros(n)
    passive = np.zeros(n, dtype=bool)
    ata, atb = a.T @ a, a.T @ b
    for _ in range(iters):
        w = atb - ata @ x
        if passive.all() or w[~passive].max() <= 1e-10 * max(1.0, abs(atb).max()):
            break
        j = np.where(~passive)[0][np.argmax(w[~passive])]
        passive[j] = True
        while True:
            z = np.zeros(n)
            idx = np.where(passive)[0]
            z[idx] = np.linalg.solve(ata[np.ix_(idx, idx)], atb[idx])
            if (z[idx] > 0).all():
                x = z
                break
            neg = idx[z[idx] <= 0]
            alpha = np.min(x[neg] / (x[neg] - z[neg]))
            x = x + alpha * (z - x)
            passive &= x > 1e-12
    return x


def median(p):
    """Median of a pmf on 0, 1, ..., interpolated as in deconv.rs (pmf_median)."""
    p = p / p.sum()
    acc = 0.0
    for k, v in enumerate(p):
        if v > 0 and acc + v >= 0.5:
            return k - 0.5 + (0.5 - acc) / v
        acc += v
    return len(p) - 0.5


def lagged(y):
    """Design matrix of lags 0..=K: row t holds y[t], y[t-1], ..., y[t-K]."""
    x = np.zeros((len(y), K + 1))
    for k in range(K + 1):
        x[k:, k] = y[: len(y) - k]
    return x


def poisson_em(x, n, iters=3000):
    """Maximum likelihood of p given counts n_t ~ Poisson(x_t . p) (EM from uniform)."""
    keep = x.sum(1) > 0
    x, n = x[keep], n[keep]
    p = np.full(K + 1, 1.0 / (K + 1))
    den = x.sum(0)
    for _ in range(iters):
        p = p * (x.T @ (n / np.maximum(x @ p, 1e-300))) / den
    return p / p.sum()


def trajectory(rng, steps, epsilon):
    """Rewards earned per step on the paper's 9x9 world by a fixed shortest path."""
    r, c = 8, 8
    y = np.zeros(steps)
    for t in range(steps):
        if (r, c) == (0, 0):
            y[t] = 10.0
            r, c = 8, 8
            continue
        a = rng.integers(4) if rng.random() < epsilon else (0 if r > 0 else 2)
        dr, dc = [(-1, 0), (1, 0), (0, -1), (0, 1)][a]
        if 0 <= r + dr < 9 and 0 <= c + dc < 9:
            r, c = r + dr, c + dc
        else:
            y[t] = -1.0
    return y


def delays(rng, kind, n):
    if kind == "uniform":
        return rng.integers(0, 27, size=n), 13.0
    if kind == "poisson13":
        return rng.poisson(13, size=n), 12.836
    lo = rng.random(n) < 0.5
    return np.where(lo, rng.poisson(3, size=n), rng.poisson(25, size=n)), None


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seeds", type=int, default=10)
    ap.add_argument("--steps", type=int, default=50_000)
    ap.add_argument("--epsilon", type=float, default=0.05)
    ap.add_argument("--delay", choices=["uniform", "poisson13", "mixture"], default="uniform")
    ap.add_argument("--bic", action="store_true", help="also fit with the support chosen by BIC")
    ap.add_argument("--split", action="store_true", help="also fit +10 and -1 deliveries apart")
    args = ap.parse_args()
    errors, split_errors = [], {"nnls": [], "em": [], "em, +10 alone": []}
    for seed in range(args.seeds):
        rng = np.random.default_rng(seed)
        y = trajectory(rng, args.steps, args.epsilon)
        d, truth = delays(rng, args.delay, args.steps)
        delivered = np.zeros(args.steps + K + 1)
        np.add.at(delivered, np.arange(args.steps) + np.minimum(d, K), y)
        delivered = delivered[: args.steps]
        x = lagged(y)
        if args.split:
            xs, ns = [], []
            for part in ((y > 0).astype(float), (y < 0).astype(float)):
                arrived = np.zeros(args.steps + K + 1)
                np.add.at(arrived, np.arange(args.steps) + np.minimum(d, K), part)
                xs.append(lagged(part))
                ns.append(arrived[: args.steps])
            goal_only = poisson_em(xs[0], ns[0])
            xs, ns = np.vstack(xs), np.concatenate(ns)
            fits = {"nnls": nnls(xs, ns), "em": poisson_em(xs, ns), "em, +10 alone": goal_only}
            for name, q in fits.items():
                q = q / q.sum()
                if truth is None:
                    print(f"seed {seed}: split {name}: mass below 12 steps {q[:12].sum():.2f} (truth 0.50)")
                else:
                    split_errors[name].append(median(q) - truth)
                    print(f"seed {seed}: split {name}: median {median(q):.2f} (truth {truth:.2f})")
        p = nnls(x, delivered)
        p /= p.sum()
        tail = p[27:].sum()
        if args.bic:
            n = args.steps
            best = None
            for m in range(5, K + 1):
                q = nnls(x[:, : m + 1], delivered)
                rss = float(np.sum((x[:, : m + 1] @ q - delivered) ** 2))
                bic = n * np.log(rss / n) + (m + 1) * np.log(n)
                if best is None or bic < best[0]:
                    best = (bic, m, q)
            q = best[2] / best[2].sum()
            print(f"seed {seed}: BIC support 0..={best[1]}, median {median(q):.2f}, mass below 12 steps {q[:12].sum():.2f}")
        if truth is None:
            print(f"seed {seed}: mass below 12 steps {p[:12].sum():.2f} (truth 0.50), beyond 26: {tail:.2f}")
        else:
            errors.append(median(p) - truth)
            print(f"seed {seed}: median {median(p):.2f} (truth {truth:.2f}), mass beyond 26: {tail:.2f}")
    if errors:
        e = np.array(errors)
        print(f"median error: mean {e.mean():+.2f}, worst {np.abs(e).max():.2f} over {len(e)} seeds")
    for name, e in split_errors.items():
        if e:
            e = np.array(e)
            print(f"split {name}: median error mean {e.mean():+.2f}, worst {np.abs(e).max():.2f} over {len(e)} seeds")


if __name__ == "__main__":
    main()
