#!/usr/bin/env python3
"""Upper bound on the vertical capacity of ten UAVs at the 20 N clamp, any formation
(docs/design.md, "The shaped formation of a packed team").

Ten points with the paper's cable lengths, the load at the origin, taut cables, equal tensions
(`sum_i p_i / L_i = 0`), every pair at least D apart horizontally, optionally all within a band
of width Y across the tube: maximise `20 N x sum_i cos theta_i`. Multi-start SLSQP.
Needs numpy and scipy (`python3 -m venv v && v/bin/pip install numpy scipy`).
"""
import itertools

import numpy as np
from scipy.optimize import minimize

L = np.array([8.3, 7.0, 8.6, 8.8, 8.3, 8.5, 8.4, 7.7, 8.3, 7.3])  # the paper's cables, m
N = len(L)
PAIRS = list(itertools.combinations(range(N), 2))
CLAMP_N = 20.0


def unpack(v):
    return v[: 2 * N].reshape(N, 2), v[2 * N]


def neg_cos_sum(v):
    p, _ = unpack(v)
    return -(np.sqrt(np.maximum(L**2 - (p**2).sum(1), 1e-9)) / L).sum()


def constraints(d, band):
    def apart(v):
        p, _ = unpack(v)
        return np.array([np.sum((p[i] - p[j]) ** 2) - d * d for i, j in PAIRS])

    out = [{"type": "ineq", "fun": apart}, {"type": "eq", "fun": lambda v: (unpack(v)[0] / L[:, None]).sum(0)}]
    if band is not None:
        out.append({"type": "ineq", "fun": lambda v: band / 2 - np.abs(unpack(v)[0][:, 1] - unpack(v)[1])})
    return out


def best(d, band, starts=60, seed=0):
    rng = np.random.default_rng(seed)
    found = None
    cons = constraints(d, band)
    for _ in range(starts):
        p0 = rng.uniform(-2.5, 2.5, (N, 2)) if band is None else np.c_[rng.uniform(-4, 4, N), rng.uniform(-band / 2, band / 2, N)]
        r = minimize(neg_cos_sum, np.r_[p0.ravel(), 0.0], method="SLSQP", constraints=cons, options={"maxiter": 500, "ftol": 1e-10})
        feasible = r.success and all(c["fun"](r.x).min() > -1e-6 for c in cons if c["type"] == "ineq")
        if feasible and (found is None or r.fun < found.fun):
            found = r
    return None if found is None else -found.fun * CLAMP_N


if __name__ == "__main__":
    print(f"the 19.8 kg load: {19.8 * 9.81:.1f} N")
    for band in [None, 3.41, 3.0]:
        for d in [1.09, 1.2, 1.3, 1.39]:
            print(f"band {band} m, pairs {d} m apart: {best(d, band):.2f} N")
