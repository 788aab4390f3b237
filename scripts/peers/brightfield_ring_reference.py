"""Independent ring-fit centres for fixtures/real/brightfield (the 0.5 px check).

Made differently from nanopush's detector (no band-pass, no radial symmetry,
no profile model): seeds are the centroids of the bright (>= 85 % of max) cores; along 90
rays from the seed the dark ring's minimum is found (profile sampled every
0.05 px with bilinear interpolation, parabolic refinement of the minimum); a
least-squares circle (Kasa algebraic fit, then 2 geometric Gauss-Newton
steps) through those edge points gives the centre. Rays are recast from the
new centre twice.

Run: scripts/peers/.venv/bin/python scripts/peers/brightfield_ring_reference.py
Writes fixtures/real/reference/<frame>.ringfit.csv (x, y, r in pixels, pixel
centres at integer coordinates).
"""
from pathlib import Path

import numpy as np
from PIL import Image
from scipy import ndimage

root = Path(__file__).resolve().parents[2]
real = root / "fixtures" / "real"


def circle_fit(pts):
    x, y = pts[:, 0], pts[:, 1]
    a = np.c_[2 * x, 2 * y, np.ones_like(x)]
    b = x * x + y * y
    cx, cy, c = np.linalg.lstsq(a, b, rcond=None)[0]
    r = np.sqrt(c + cx * cx + cy * cy)
    for _ in range(2):
        d = np.hypot(x - cx, y - cy)
        j = np.c_[-(x - cx) / d, -(y - cy) / d, -np.ones_like(d)]
        res = d - r
        step = np.linalg.lstsq(j, -res, rcond=None)[0]
        cx, cy, r = cx + step[0], cy + step[1], r + step[2]
    return cx, cy, r


def ring_points(img, cx, cy, rmin=4.0, rmax=13.0, rays=90):
    rs = np.arange(rmin, rmax, 0.05)
    pts = []
    for t in np.linspace(0, 2 * np.pi, rays, endpoint=False):
        xs, ys = cx + rs * np.cos(t), cy + rs * np.sin(t)
        prof = ndimage.map_coordinates(img, [ys, xs], order=1, mode="nearest")
        k = int(np.argmin(prof))
        if 0 < k < len(rs) - 1:
            y0, y1, y2 = prof[k - 1], prof[k], prof[k + 1]
            den = y0 - 2 * y1 + y2
            off = 0.5 * (y0 - y2) / den if den > 0 else 0.0
            r = rs[k] + off * 0.05
            pts.append((cx + r * np.cos(t), cy + r * np.sin(t)))
    return np.array(pts)


for p in sorted((real / "brightfield").glob("*.png")):
    img = np.asarray(Image.open(p)).astype(float)
    if img.ndim == 3:
        img = img[..., 0]
    lab, n = ndimage.label(img >= 0.85 * img.max())
    seeds = [c for c, s in zip(ndimage.center_of_mass(np.ones_like(img), lab, range(1, n + 1)),
                               ndimage.sum(np.ones_like(img), lab, range(1, n + 1))) if s >= 4]
    rows = []
    for sy, sx in seeds:
        cx, cy = sx, sy
        for _ in range(3):
            cx, cy, r = circle_fit(ring_points(img, cx, cy))
        rows.append((cx, cy, r))
    out = real / "reference" / f"{p.stem}.ringfit.csv"
    with open(out, "w") as f:
        f.write("# least-squares circle through the dark ring minima; scripts/peers/brightfield_ring_reference.py\n")
        f.write("x,y,r\n")
        for cx, cy, r in rows:
            f.write(f"{cx:.4f},{cy:.4f},{r:.4f}\n")
    print(out, len(rows), [f"({x:.2f},{y:.2f},{r:.2f})" for x, y, r in rows])
