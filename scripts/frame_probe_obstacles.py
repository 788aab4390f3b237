"""What `plan --frame` holds near the probe, over frames with the probe at
random places: the obstacles it marks (each should lie on a true particle)
and the true particles in no layout (those the probe's body hides).

    python3 scripts/frame_probe_obstacles.py target/release/nanopush

Works in a temporary folder; prints a line a frame and the totals.
"""
import json
import math
import os
import random
import subprocess
import sys
import tempfile


def main(binary, frames=24):
    random.seed(7)
    held, far, unseen = 0, 0, 0
    with tempfile.TemporaryDirectory() as d:
        at = lambda name: os.path.join(d, name)
        for seed in range(1, frames + 1):
            run = lambda *a: subprocess.run([binary, *a], capture_output=True, text=True)
            run("synth", "layout", "--n", "40", "--field-um", "120x100", "--seed", str(seed), "--out", at("t.json"))
            x, y, angle = random.uniform(20, 220), random.uniform(20, 180), random.uniform(0, 360)
            run("synth", "frame", "--layout", at("t.json"), "--um-per-px", "0.5", "--seed", str(seed),
                "--tip-x-px", f"{x:.1f}", "--tip-y-px", f"{y:.1f}", "--tip-angle-deg", f"{angle:.1f}",
                "--out", at("f.png"), "--calib-out", at("cal.toml"), "--force")
            run("plan", "--text", "I", "--frame", at("f.png"), "--calib", at("cal.toml"),
                "--save-layout", at("s.json"), "--json")
            truth = json.load(open(at("t.json")))["particles"]
            seen = json.load(open(at("s.json")))["particles"]
            dist = lambda p, q: math.hypot(p["x_um"] - q["x_um"], p["y_um"] - q["y_um"])
            marked = [p for p in seen if p.get("immovable")]
            held += len(marked)
            far += sum(min(dist(p, q) for q in truth) > 2.2 for p in marked)
            missing = sum(min(dist(p, q) for p in seen) > 2.2 for q in truth)
            unseen += missing
            print(f"seed {seed}: probe apex ({x:.0f}, {y:.0f}) px at {angle:.0f} deg: "
                  f"{len(marked)} held, {missing} of {len(truth)} in no layout")
    print(f"held {held}, of them farther than 2.2 um from a true particle {far}; "
          f"true particles in no layout {unseen}")


if __name__ == "__main__":
    main(sys.argv[1])
