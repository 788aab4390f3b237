"""Reference data for nanopush's real-frame vision tests, made with trackpy.

Run once (from the repository root) after scripts/peers/setup-venv.sh:
    scripts/peers/.venv/bin/python scripts/peers/make_fixtures.py

Writes:
- fixtures/real/reference/<frame>.trackpy.csv: trackpy 0.7 `locate` detections
  (x, y in pixels, pixel centres at integers) with the parameters from
  /work/shared/data/real/README.md;
- fixtures/real/trackpy_tests/stuck_crop_be16.tif: the first 2 pages of
  trackpy's stuck.tif, cropped to the 128x128 window with the most features, written as a big-endian 16-bit
  multi-page TIFF (a small real fixture for the TIFF-stack reader);
- fixtures/real/reference/stuck_crop.trackpy.csv: trackpy on that crop (page 0).
"""
import sys
from pathlib import Path

import numpy as np
import tifffile
import trackpy as tp
from PIL import Image

root = Path(__file__).resolve().parents[2]
real = root / "fixtures" / "real"
ref = real / "reference"
ref.mkdir(parents=True, exist_ok=True)
shared = Path("/work/shared/data/real")


def save(df, name, params):
    out = ref / f"{name}.trackpy.csv"
    with open(out, "w") as f:
        f.write(f"# trackpy {tp.__version__} locate({params}); x,y in pixels\n")
        f.write("x,y,mass\n")
        for x, y, m in zip(df["x"], df["y"], df["mass"]):
            f.write(f"{x:.4f},{y:.4f},{m:.2f}\n")
    print(out, len(df))


for p in sorted((real / "bulk_water").glob("*.png")):
    green = np.asarray(Image.open(p))[..., 1]
    save(tp.locate(green, 11, invert=True, minmass=20), p.stem, "green, 11, invert=True, minmass=20")

for p in sorted((real / "trackpy_tests").glob("T76*.png")):
    img = np.asarray(Image.open(p))
    if img.ndim == 3:
        img = img[..., 0]
    save(tp.locate(tp.invert_image(img), 9, minmass=140), p.stem, "invert(frame), 9, minmass=140")

stack = tifffile.imread(shared / "trackpy_tests" / "stuck.tif")
full = tp.locate(stack[0], 7, minmass=100)
# The 128x128 window (step 32) holding the most trackpy features.
best = max(
    ((y0, x0) for y0 in range(0, 385, 32) for x0 in range(0, 385, 32)),
    key=lambda c: int(((full.y >= c[0] + 8) & (full.y < c[0] + 120) & (full.x >= c[1] + 8) & (full.x < c[1] + 120)).sum()),
)
y0, x0 = best
print("stuck crop origin (x, y):", x0, y0, file=sys.stderr)
crop = np.ascontiguousarray(stack[:2, y0:y0 + 128, x0:x0 + 128].astype(">u2"))
tifffile.imwrite(real / "trackpy_tests" / "stuck_crop_be16.tif", crop, byteorder=">")
save(tp.locate(crop[0].astype(np.uint16), 7, minmass=100), "stuck_crop", f"page 0 of stuck.tif[{y0}:{y0+128}, {x0}:{x0+128}], 7, minmass=100")
print("full stuck.tif page 0:", len(tp.locate(stack[0], 7, minmass=100)), file=sys.stderr)
