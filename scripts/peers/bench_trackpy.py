"""trackpy side by side with nanopush's benchmark (benches/vision.rs), one core.

Frames:
- out/bench_1024.png: made by
  `nanopush synth frame --n 100 --seed 42 --snr 10 --bits 16 --tip-x-px 600 --tip-y-px 500 --tip-angle-deg 22.918 --out out/bench_1024.png`
  (the same scene and seed as the criterion bench), or the bench's own frame
  written by the same render call;
- fixtures/real/bulk_water/bulk_water_000.png (green channel).

Run: OMP_NUM_THREADS=1 scripts/peers/.venv/bin/python scripts/peers/bench_trackpy.py
Prints the median time per frame of trackpy.locate over 15 runs, wall clock
and this thread's CPU time (time.thread_time; the machine is shared, so the
CPU time is the figure comparable with the bench's `*_cpu_time` groups).
"""
import os
import statistics
import time
from pathlib import Path

import numpy as np
import trackpy as tp
from PIL import Image

os.environ.setdefault("OMP_NUM_THREADS", "1")
root = Path(__file__).resolve().parents[2]


def median_ms(fn, n=15):
    """Median wall-clock and thread-CPU milliseconds per call, as a string."""
    fn()
    wall, cpu = [], []
    for _ in range(n):
        t0, c0 = time.perf_counter(), time.thread_time()
        fn()
        wall.append(time.perf_counter() - t0)
        cpu.append(time.thread_time() - c0)
    return f"wall {1e3 * statistics.median(wall):.1f} ms, cpu {1e3 * statistics.median(cpu):.1f}"


bench = root / "out" / "bench_1024.png"
if bench.exists():
    img = np.asarray(Image.open(bench)).astype(np.float64)
    f = tp.locate(img, 19, minmass=1e5)
    print(f"bench_1024 (1024x1024 16-bit, 100 rings + tip): trackpy.locate(diameter=19) "
          f"{median_ms(lambda: tp.locate(img, 19, minmass=1e5))} ms/frame, {len(f)} features")
else:
    print(f"{bench} missing; make it with nanopush synth frame (see docstring)")
green = np.asarray(Image.open(root / "fixtures/real/bulk_water/bulk_water_000.png"))[..., 1]
print(f"bulk_water_000 (640x424): trackpy.locate(11, invert=True, minmass=20) "
      f"{median_ms(lambda: tp.locate(green, 11, invert=True, minmass=20))} ms/frame")
