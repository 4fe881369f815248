#!/usr/bin/env python3
"""Stride periods of a recorded episode: how often each foot touches down.

Reads the `/tf` topic of a Centaur MCAP recording (`centaur compare` writes one per agent
for seed 0, `centaur eval --record` any), takes each foot frame's height over the episode,
counts a touchdown where it comes within `--contact` metres of its lowest, and prints per
foot the touchdowns, the median time between them and the fraction of steps near the
ground. Used for the README's "Walker2d: the controller's clock sets the cadence".

    python3 -m venv /tmp/v && /tmp/v/bin/pip install mcap numpy
    /tmp/v/bin/python tools/stride_periods.py runs/X/seed_0/hybrid.mcap [--feet foot foot_left]
"""

import argparse
import json

import numpy as np
from mcap.reader import make_reader


def foot_heights(path, feet):
    heights = {f: [] for f in feet}
    times = []
    with open(path, "rb") as f:
        for _, _, message in make_reader(f).iter_messages(topics=["/tf"]):
            frame = json.loads(message.data)
            seen = False
            for tr in frame["transforms"]:
                if tr["child_frame_id"] in heights:
                    heights[tr["child_frame_id"]].append(tr["translation"]["z"])
                    if not seen:
                        ts = tr["timestamp"]
                        times.append(ts["sec"] + 1e-9 * ts["nsec"])
                        seen = True
    return np.array(times), {f: np.array(z) for f, z in heights.items()}


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("recordings", nargs="+")
    ap.add_argument("--feet", nargs="+", default=["foot", "foot_left"], help="foot frames (Walker2d's)")
    ap.add_argument("--contact", type=float, default=0.03, help="height above its lowest counted as contact (m)")
    args = ap.parse_args()
    for path in args.recordings:
        times, heights = foot_heights(path, args.feet)
        print(path)
        for foot, z in heights.items():
            if len(z) < 3:
                print(f"  {foot}: not recorded")
                continue
            down = z < z.min() + args.contact
            touchdowns = np.flatnonzero(~down[:-1] & down[1:]) + 1
            at = times[touchdowns] if len(times) == len(z) else touchdowns.astype(float)
            period = float(np.median(np.diff(at))) if len(at) > 1 else float("nan")
            print(f"  {foot}: {len(touchdowns)} touchdowns, median {period:.3f} s apart, near the ground {down.mean():.0%} of steps")


if __name__ == "__main__":
    main()
