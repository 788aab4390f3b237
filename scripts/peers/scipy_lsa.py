#!/usr/bin/env python3
"""Peer check: scipy.optimize.linear_sum_assignment on an instance written by
`nanopush study plan --dump-dir DIR` (same sites and particles, um).
Prints the total cost (um) and the solve time, to compare with nanopush's
exact assignment on the same file. Outside the product; run in .venv-scipy."""
import json, sys, time
import numpy as np
from scipy.optimize import linear_sum_assignment
from scipy.spatial.distance import cdist

for path in sys.argv[1:]:
    inst = json.load(open(path))
    s = np.asarray(inst["sites"], dtype=float)
    p = np.asarray(inst["particles"], dtype=float)
    t0 = time.perf_counter()
    c = cdist(s, p)
    r, k = linear_sum_assignment(c)
    dt = time.perf_counter() - t0
    print(json.dumps({"file": path, "n": len(s), "m": len(p), "cost_um": float(c[r, k].sum()), "time_s": dt}))
