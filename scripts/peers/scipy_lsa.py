#!/usr/bin/env python3
"""Peer check: scipy.optimize.linear_sum_assignment on instances written by
`nanopush study plan --dump-dir DIR` (nanopush.assignment-instance/1: the same
sites and particles, um). Prints one JSON line per file: the total cost (um),
the time of the cost matrix (cdist) and of the solve, to put beside
`nanopush study plan` on the same sizes and seed. Outside the product; run
in .venv-scipy (scripts/peers/setup-venv-scipy.sh)."""
import json, sys, time
import numpy as np
import scipy
from scipy.optimize import linear_sum_assignment
from scipy.spatial.distance import cdist

for path in sys.argv[1:]:
    inst = json.load(open(path))
    if inst.get("schema") != "nanopush.assignment-instance/1":
        sys.exit(f"{path}: schema {inst.get('schema')!r}, expected nanopush.assignment-instance/1")
    s = np.asarray(inst["sites"], dtype=float)
    p = np.asarray(inst["particles"], dtype=float)
    t0 = time.perf_counter()
    c = cdist(s, p)
    t1 = time.perf_counter()
    r, k = linear_sum_assignment(c)
    t2 = time.perf_counter()
    print(json.dumps({"file": path, "n": len(s), "m": len(p), "cost_um": float(c[r, k].sum()),
                      "cdist_s": t1 - t0, "solve_s": t2 - t1, "time_s": t2 - t0,
                      "scipy": scipy.__version__}), flush=True)
