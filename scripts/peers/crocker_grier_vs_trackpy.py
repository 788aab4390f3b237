"""nanopush's Crocker-Grier mode (src/vision/crocker_grier.rs) against trackpy.

Outside the product. Two parts:

1. Black-box checks of the rounding rules the Rust module states, each
   computed from trackpy's public functions and printed as pass/fail:
   - `bandpass(img, 1, llong)` on an integer image equals a Gaussian blur
     (sigma 1, truncate 4, zero outside) minus a boxcar of side `llong` with
     edge pixels repeated, each axis pass (y, then x) rounded down to whole
     counts, clipped below 1;
   - `convert_to_int` scales to the dtype's maximum and truncates;
   - `grey_dilation`'s square of even side s reaches offsets -(s-1)//2 .. +s//2.
2. `nanopush detect --locator crocker-grier --json` against `trackpy.locate`
   with the same call on each frame: counts, matches within 1.5 px, worst
   offset of the matched pairs.

Run from the repository root after scripts/peers/setup-venv.sh and a build:
    scripts/peers/.venv/bin/python scripts/peers/crocker_grier_vs_trackpy.py [path/to/nanopush]
The binary defaults to target/release/nanopush. out/bench_1024.png is
compared too when it exists (see bench_trackpy.py for how to make it).
"""
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import trackpy as tp
from PIL import Image
from scipy import ndimage as ndi
from scipy.spatial import cKDTree

root = Path(__file__).resolve().parents[2]
nanopush = Path(sys.argv[1]) if len(sys.argv) > 1 else root / "target/release/nanopush"


def check(name, ok):
    print(f"{'PASS' if ok else 'FAIL'}  {name}")
    return ok


def rounding_rules(img):
    """The rules of part 1 on one integer image."""
    f = img.astype(float)
    gauss = ndi.gaussian_filter(f, 1, truncate=4, mode="constant")
    floored = np.floor(ndi.uniform_filter1d(f, 11, axis=0, mode="nearest") + 1e-9)
    floored = np.floor(ndi.uniform_filter1d(floored, 11, axis=1, mode="nearest") + 1e-9)
    mine = gauss - floored
    mine = np.where(mine >= 1, mine, 0)
    bp = tp.preprocessing.bandpass(img, 1, 11)
    check("bandpass = gaussian(zero edges) - floored boxcar(nearest edges)", np.abs(mine - bp).max() < 1e-9)
    scale, levels = tp.preprocessing.convert_to_int(bp, img.dtype)
    want = (bp * (np.iinfo(img.dtype).max / bp.max())).astype(img.dtype)
    check("convert_to_int scales to the dtype maximum and truncates", np.array_equal(levels, want))
    rng = np.random.default_rng(1)
    a = rng.integers(0, 255, (40, 40)).astype(np.uint8)
    d = ndi.grey_dilation(a, (16, 16), mode="constant")
    ok = all(
        a[max(0, y - 7): y + 9, max(0, x - 7): x + 9].max() == d[y, x]
        for y in range(40)
        for x in range(40)
    )
    check("grey_dilation side 16 covers offsets -7..+8", ok)


def compare(label, frame_path, channel, image, diameter, minmass, invert):
    """Part 2 on one frame."""
    ref = tp.locate(image, diameter, invert=invert, minmass=minmass)
    cmd = [str(nanopush), "detect", str(frame_path), "--locator", "crocker-grier",
           "--diameter-px", str(diameter), "--minmass", str(minmass), "--no-tip",
           "--json", "--channel", channel]
    if invert:
        cmd += ["--polarity", "dark"]
    doc = json.loads(subprocess.run(cmd, check=True, capture_output=True, text=True).stdout)
    ours = np.array([[p["x_px"], p["y_px"]] for p in doc["particles"]]).reshape(-1, 2)
    theirs = ref[["x", "y"]].to_numpy()
    dist, _ = cKDTree(ours).query(theirs) if len(ours) else (np.full(len(theirs), np.inf), None)
    matched = dist <= 1.5
    worst = dist[matched].max() if matched.any() else float("nan")
    print(f"{label}: trackpy {len(theirs)}, nanopush {len(ours)}, "
          f"matched {100 * matched.mean():.1f} %, worst matched offset {worst:.2e} px")


real = root / "fixtures/real"
green = np.asarray(Image.open(real / "bulk_water/bulk_water_000.png"))[..., 1]
rounding_rules(tp.invert_image(green))
for name in ["bulk_water_000", "bulk_water_100"]:
    p = real / f"bulk_water/{name}.png"
    compare(name, p, "green", np.asarray(Image.open(p))[..., 1], 11, 20, True)
p = real / "trackpy_tests/T76S3F00001.png"
img = np.asarray(Image.open(p))
compare("T76S3F00001", p, "luminance", img if img.ndim == 2 else img[..., 0], 9, 140, True)
bench = root / "out/bench_1024.png"
if bench.exists():
    compare("bench_1024", bench, "luminance", np.asarray(Image.open(bench)), 19, 100000, False)
