#!/usr/bin/env python3
"""Reads a gait off a Centaur MCAP recording (the `/tf`, `/contacts` and `/metrics` topics).

Prints, per second of the episode, the forward speed, the base height and (in controller
and hybrid runs) the commanded speed and the gait clock's rate; then, over the steady part
(from --from seconds), the stance patterns' shares, the stride frequency (touchdowns of each
foot per second) and the episode's return. Feet are named by where their contact lies in
the base's heading frame (F/B: ahead of or behind the base, L/R: left or right), so it
works for any four-legged robot without knowing its frame names.

    pip install mcap
    python3 tools/gait_from_mcap.py runs/quarter_state/seed_0/hybrid.mcap
    python3 tools/gait_from_mcap.py runs/quarter_state/seed_0/pure_rl.mcap --from 2
"""

import argparse
import json
import math
from collections import Counter

from mcap.reader import make_reader


def yaw_of(q):
    return math.atan2(2 * (q["w"] * q["z"] + q["x"] * q["y"]), 1 - 2 * (q["y"] ** 2 + q["z"] ** 2))


def read(path):
    """Per control step: (time, base position, base yaw), contact points, metrics."""
    tf, contacts, metrics = [], [], []
    with open(path, "rb") as f:
        for _, channel, message in make_reader(f).iter_messages(topics=["/tf", "/contacts", "/metrics"]):
            d = json.loads(message.data)
            if channel.topic == "/tf":
                base = d["transforms"][0]
                stamp = base["timestamp"]
                tf.append((stamp["sec"] + 1e-9 * stamp["nsec"], base["translation"], yaw_of(base["rotation"])))
            elif channel.topic == "/contacts":
                contacts.append([a["pose"]["position"] for e in d["entities"] for a in e.get("arrows", [])])
            else:
                metrics.append(d)
    return tf, contacts, metrics


def stance(base, yaw, points):
    """The feet in contact, named by quadrant of the heading frame, e.g. 'BRFL'."""
    c, s = math.cos(yaw), math.sin(yaw)
    feet = set()
    for p in points:
        dx, dy = p["x"] - base["x"], p["y"] - base["y"]
        ahead, left = c * dx + s * dy, -s * dx + c * dy
        feet.add(("F" if ahead > 0 else "B") + ("L" if left > 0 else "R"))
    return "".join(sorted(feet)) or "-"


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("recording")
    parser.add_argument("--from", dest="start", type=float, default=1.0, help="steady part starts here, s")
    args = parser.parse_args()
    tf, contacts, metrics = read(args.recording)
    if not tf:
        raise SystemExit(f"{args.recording}: no /tf messages")
    dt = tf[1][0] - tf[0][0] if len(tf) > 1 else 0.01

    def mean(key, lo, hi):
        vals = [m[key] for m in metrics[lo:hi] if isinstance(m.get(key), (int, float))]
        return sum(vals) / len(vals) if vals else float("nan")

    per_second = max(1, round(1.0 / dt))
    print("| s | forward speed (m/s) | base height (m) | commanded speed (m/s) | gait clock rate |")
    print("|---:|---:|---:|---:|---:|")
    for lo in range(0, len(tf), per_second):
        hi = lo + per_second
        height = sum(p["z"] for _, p, _ in tf[lo:hi]) / len(tf[lo:hi])
        print(
            f"| {tf[lo][0]:.0f}–{tf[min(hi, len(tf)) - 1][0]:.0f} | {mean('forward_velocity', lo, hi):.2f} "
            f"| {height:.3f} | {mean('commanded_speed', lo, hi):.2f} | {mean('gait_rate', lo, hi):.2f} |"
        )
    first = next((i for i, (t, _, _) in enumerate(tf) if t >= args.start), len(tf))
    patterns = [stance(p, yaw, c) for (_, p, yaw), c in zip(tf, contacts)]
    steady = patterns[first:]
    if not steady:
        raise SystemExit(f"the episode ends before --from {args.start} s")
    print(f"\nstance patterns from {args.start} s (share of steps):")
    for pattern, n in Counter(steady).most_common(8):
        print(f"  {pattern:8s} {n / len(steady):.2f}")
    seconds = len(steady) * dt
    for foot in ["FL", "FR", "BL", "BR"]:
        touchdowns = sum(1 for a, b in zip(steady, steady[1:]) if foot not in a and foot in b)
        print(f"  {foot} touchdowns per second: {touchdowns / seconds:.2f}")
    x0, x1 = tf[first][1]["x"], tf[-1][1]["x"]
    print(f"steady forward speed {(x1 - x0) / max(tf[-1][0] - tf[first][0], dt):.2f} m/s; "
          f"yaw at the end {math.degrees(tf[-1][2]):.1f}°; return "
          f"{sum(m.get('reward', 0.0) for m in metrics):.2f} over {len(tf)} steps")


if __name__ == "__main__":
    main()
