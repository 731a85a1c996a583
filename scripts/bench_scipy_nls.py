#!/usr/bin/env python3
"""Times scipy.optimize.least_squares on the range-only NLS problems `trigait bench` exported.

Each problem is the weighted range residual r_i(x) = (|x - k_i| - range_i) / sigma_i with its
analytic Jacobian, started from the same linear-trilateration point our solver starts from, and
solved with Levenberg-Marquardt (method="lm", MINPACK) as our `nls` is. Prints one JSON object:
{"solves_per_sec": ..., "solutions": [[x, y, z], ...], "scipy": version}.
"""
import json
import sys
import time

import numpy as np
import scipy
from scipy.optimize import least_squares


def solve(problem):
    k = np.asarray(problem["sensors"], dtype=float)
    r = np.asarray(problem["ranges"], dtype=float)
    w = 1.0 / np.asarray(problem["sigmas"], dtype=float)

    def fun(x):
        return (np.linalg.norm(x - k, axis=1) - r) * w

    def jac(x):
        d = x - k
        return d / np.linalg.norm(d, axis=1)[:, None] * w[:, None]

    result = least_squares(fun, np.asarray(problem["start"], dtype=float), jac=jac,
                           method="lm", xtol=1e-12, ftol=1e-12, gtol=1e-12)
    return result.x


def main():
    with open(sys.argv[1]) as f:
        problems = json.load(f)["problems"]
    solutions = [solve(p) for p in problems[:16]]  # warm-up
    best = float("inf")
    for _ in range(3):
        start = time.perf_counter()
        solutions = [solve(p) for p in problems]
        best = min(best, time.perf_counter() - start)
    print(json.dumps({
        "solves_per_sec": len(problems) / best,
        "solutions": [list(map(float, s)) for s in solutions],
        "scipy": scipy.__version__,
    }))


if __name__ == "__main__":
    main()
