#!/usr/bin/env python3
"""Reads a gait off a Centaur MCAP recording (the `/tf`, `/contacts` and `/metrics` topics).

Prints, per second of the episode, the forward speed, the base height and (in controller
and hybrid runs) the commanded speed and the gait clock's rate; then, over the steady part
(from --from seconds), the stance patterns' shares, the stride frequency (touchdowns of
each foot per second), the speed along world x (the reward's axis) and the episode's
return. Feet are named by where their contact lies in the base's heading frame (F/B: ahead
of or behind the base, L/R: left or right), so it works for any four-legged robot without
knowing its frame names. Tested by `python/tests/test_gait_tool.py` (a recording of known
gait in the recorder's shapes).

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


def summarize(tf, contacts, metrics, start=1.0):
    """The gait of a recording read by `read`: per second of the episode the forward speed,
    base height, commanded speed and clock rate; from `start` seconds on the stance
    patterns' shares (most common first), each foot's touchdowns per second and the speed
    along world x (the axis the Minitaur's reward counts); the yaw at the end and the
    episode's return. Raises ValueError on a recording without /tf or shorter than `start`."""
    if not tf:
        raise ValueError("no /tf messages")
    dt = tf[1][0] - tf[0][0] if len(tf) > 1 else 0.01

    def mean(key, lo, hi):
        vals = [m[key] for m in metrics[lo:hi] if isinstance(m.get(key), (int, float))]
        return sum(vals) / len(vals) if vals else float("nan")

    per_second = max(1, round(1.0 / dt))
    seconds = []
    for lo in range(0, len(tf), per_second):
        hi = lo + per_second
        seconds.append({
            "from": tf[lo][0],
            "to": tf[min(hi, len(tf)) - 1][0],
            "forward_velocity": mean("forward_velocity", lo, hi),
            "height": sum(p["z"] for _, p, _ in tf[lo:hi]) / len(tf[lo:hi]),
            "commanded_speed": mean("commanded_speed", lo, hi),
            "gait_rate": mean("gait_rate", lo, hi),
        })
    first = next((i for i, (t, _, _) in enumerate(tf) if t >= start), len(tf))
    patterns = [stance(p, yaw, c) for (_, p, yaw), c in zip(tf, contacts)]
    steady = patterns[first:]
    if not steady:
        raise ValueError(f"the episode ends before {start} s")
    span = len(steady) * dt
    touchdowns = {
        foot: sum(1 for a, b in zip(steady, steady[1:]) if foot not in a and foot in b) / span
        for foot in ["FL", "FR", "BL", "BR"]
    }
    x0, x1 = tf[first][1]["x"], tf[-1][1]["x"]
    return {
        "seconds": seconds,
        "patterns": [(p, n / len(steady)) for p, n in Counter(steady).most_common()],
        "touchdowns_per_second": touchdowns,
        "steady_speed_x": (x1 - x0) / max(tf[-1][0] - tf[first][0], dt),
        "yaw_at_end_deg": math.degrees(tf[-1][2]),
        "return": sum(m.get("reward", 0.0) for m in metrics),
        "steps": len(tf),
    }


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("recording")
    parser.add_argument("--from", dest="start", type=float, default=1.0, help="steady part starts here, s")
    args = parser.parse_args()
    try:
        g = summarize(*read(args.recording), start=args.start)
    except ValueError as e:
        raise SystemExit(f"{args.recording}: {e}")
    print("| s | forward speed (m/s) | base height (m) | commanded speed (m/s) | gait clock rate |")
    print("|---:|---:|---:|---:|---:|")
    for r in g["seconds"]:
        print(
            f"| {r['from']:.0f}–{r['to']:.0f} | {r['forward_velocity']:.2f} | {r['height']:.3f} "
            f"| {r['commanded_speed']:.2f} | {r['gait_rate']:.2f} |"
        )
    print(f"\nstance patterns from {args.start} s (share of steps):")
    for pattern, share in g["patterns"][:8]:
        print(f"  {pattern:8s} {share:.2f}")
    for foot, rate in g["touchdowns_per_second"].items():
        print(f"  {foot} touchdowns per second: {rate:.2f}")
    print(f"steady speed along x {g['steady_speed_x']:.2f} m/s; yaw at the end {g['yaw_at_end_deg']:.1f}°; "
          f"return {g['return']:.2f} over {g['steps']} steps")


if __name__ == "__main__":
    main()
