"""False tips on probe-free frames and true tips kept, the tip search's
soft-shape rule's figures (docs/vision.md, tip row; src/vision/tip.rs,
`probe_like`).

    python3 scripts/tip_false_study.py target/release/nanopush [REAL_DIR]

Needs numpy and opencv-python. Makes, in a temporary folder, 1024 x 1024
frames of 60 particles with and without the probe (4 seeds), blurred at
sigma 0, 1, 2, 3, 4, 6 px (the camera noise the blur takes put back), each
plain, vignetted and graded ("vig"), under 4 soft dark dirt blobs, two cut
by the edge ("dirt"), or both ("shaded"); and 12 hard probes: half the
contrast, and the apex 20, 25, 30 px inside the top edge, at sigma 0, 3, 6.
REAL_DIR (../shared/data/real) adds its frames, probe-free, as they are and
blurred at sigma 3 and 6. Prints a line per frame with a tip and the totals:
tips on probe-free frames, and probes found (within 10 px).
"""
import glob
import json
import math
import os
import subprocess
import sys
import tempfile

import cv2
import numpy as np

W = H = 1024
TIPS = {1: (520, 470, 30), 2: (380, 600, -120), 3: (640, 420, 160), 4: (470, 520, 75)}
SIGMAS = [0, 1, 2, 3, 4, 6]
CONDS = ["plain", "vig", "dirt", "shaded"]


def noise_sigma(im):
    d = np.diff(im.astype(np.float64), axis=1).ravel()
    return 1.4826 * np.median(np.abs(d - np.median(d))) / np.sqrt(2)


def blur(im, s, n0, rng):
    """Gaussian blur of sigma s, with the camera noise it removed put back."""
    if s == 0:
        return im
    b = cv2.GaussianBlur(im, (0, 0), s)
    return b + rng.normal(0, n0 * np.sqrt(max(0.0, 1 - 1 / (4 * np.pi * s * s))), im.shape)


def shading(rng):
    yy, xx = np.mgrid[0:H, 0:W].astype(np.float64)
    cx, cy = W / 2 + rng.uniform(-150, 150), H / 2 + rng.uniform(-150, 150)
    vign = 1.0 - 0.30 * ((xx - cx) ** 2 + (yy - cy) ** 2) / ((W / 2) ** 2 + (H / 2) ** 2)
    a = rng.uniform(0, 2 * np.pi)
    return vign * (1.0 + 0.12 * ((xx - W / 2) * np.cos(a) + (yy - H / 2) * np.sin(a)) / (W / 2))


def dirt(rng):
    yy, xx = np.mgrid[0:H, 0:W].astype(np.float64)
    t = np.ones((H, W))
    for k in range(4):
        side, along = rng.integers(4), rng.uniform(0.1, 0.9)
        inset = rng.uniform(-20, 10) if k < 2 else rng.uniform(30, 90)
        x, y = {0: (along * W, inset), 1: (W - 1 - inset, along * H),
                2: (along * W, H - 1 - inset), 3: (inset, along * H)}[side]
        r, depth = rng.uniform(18, 45), rng.uniform(0.35, 0.65)
        t *= 1.0 - depth / (1.0 + np.exp((np.hypot(xx - x, yy - y) - r) / (0.25 * r)))
    return t


def synth(binary, d, name, seed, args):
    raw = os.path.join(d, name + "_raw.png")
    subprocess.run([binary, "synth", "frame", "--seed", str(seed), "--out", raw, *args],
                   check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    return cv2.imread(raw, cv2.IMREAD_UNCHANGED).astype(np.float64)


def frames(binary, d):
    """(path, detect options, true apex or None)."""
    for seed, (tx, ty, ta) in TIPS.items():
        for probe in (True, False):
            args = ["--n", "60", "--width-px", str(W), "--height-px", str(H)]
            if probe:
                args += ["--tip-x-px", str(tx), "--tip-y-px", str(ty), "--tip-angle-deg", str(ta)]
            raw = synth(binary, d, f"s{seed}{probe}", seed, args)
            n0 = noise_sigma(raw)
            rng = np.random.default_rng(1000 + seed)
            illum, tmap = shading(rng), dirt(rng)
            for s in SIGMAS:
                for c, cond in enumerate(CONDS):
                    im = blur(raw, s, n0, np.random.default_rng(seed * 100 + s * 10 + c))
                    im = im * (illum if cond in ("vig", "shaded") else 1) * (tmap if cond in ("dirt", "shaded") else 1)
                    path = os.path.join(d, f"s{seed}_{'p' if probe else 'n'}_b{s}_{cond}.png")
                    cv2.imwrite(path, np.clip(np.rint(im), 0, 65535).astype(np.uint16))
                    yield path, ["--diameter-px", "17"], (tx, ty) if probe else None
    for name, (tx, ty, ta), half in [("low", (500, 480, 40), True), ("edge20", (400, 20, 90), False),
                                     ("edge25", (600, 25, 90), False), ("edge30", (300, 30, 90), False)]:
        raw = synth(binary, d, name, 7, ["--n", "30", "--tip-x-px", str(tx), "--tip-y-px", str(ty),
                                      "--tip-angle-deg", str(ta)])
        n0 = noise_sigma(raw)
        if half:
            raw = np.median(raw) + 0.5 * (raw - np.median(raw))
        for s in (0, 3, 6):
            path = os.path.join(d, f"x_{name}_b{s}.png")
            cv2.imwrite(path, np.clip(np.rint(blur(raw, s, n0, np.random.default_rng(s))), 0, 65535).astype(np.uint16))
            yield path, ["--diameter-px", "17"], (tx, ty)


def real_frames(real, d):
    for f in sorted(glob.glob(os.path.join(real, "*", "*.png")) + glob.glob(os.path.join(real, "*", "*.tif"))):
        opt = (["--diameter-px", "17"] if "brightfield" in f else
               ["--diameter-px", "7", "--channel", "green"] if "bulk_water" in f else
               ["--diameter-px", "5" if f.endswith("stuck.tif") else "7"])
        im = cv2.imread(f, cv2.IMREAD_UNCHANGED)
        if im.ndim == 3:
            im = im[:, :, :3]
        for s in (0, 3, 6):
            path = f
            if s:
                path = os.path.join(d, os.path.basename(f).rsplit(".", 1)[0] + f"_b{s}.png")
                b = cv2.GaussianBlur(im.astype(np.float64), (0, 0), s)
                cv2.imwrite(path, np.clip(np.rint(b), 0, np.iinfo(im.dtype).max).astype(im.dtype))
            yield path, opt, None


def main(binary, real=None):
    false_tips, free, kept, probes = 0, 0, 0, 0
    with tempfile.TemporaryDirectory() as d:
        todo = list(frames(binary, d)) + (list(real_frames(real, d)) if real else [])
        for path, opt, truth in todo:
            out = subprocess.run([binary, "detect", path, "--json", *opt], capture_output=True, text=True).stdout
            tip = json.loads(out[out.index("{"):])["tip"]
            name = os.path.basename(path)
            if truth is None:
                free += 1
                false_tips += tip is not None
                if tip:
                    print(f"{name}: false tip at ({tip['x_px']:.0f}, {tip['y_px']:.0f}), score {tip['score']:.3f}")
            else:
                probes += 1
                err = math.hypot(tip["x_px"] - truth[0], tip["y_px"] - truth[1]) if tip else math.inf
                kept += err <= 10
                if err > 10:
                    print(f"{name}: probe not found" + (f" ({err:.1f} px off)" if tip else ""))
    print(f"tips on probe-free frames: {false_tips} of {free}; probes found: {kept} of {probes}")


if __name__ == "__main__":
    main(*sys.argv[1:3])
