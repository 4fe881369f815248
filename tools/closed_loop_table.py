#!/usr/bin/env python3
"""Runs `centaur control` on the closed-loop cases of the README and prints the Markdown table.

    cargo build --release --bin centaur && python tools/closed_loop_table.py [--only humanoid] [--mpc-solver clarabel]

No dependencies beyond the standard library; each case writes /tmp/centaur-closed-loop/<n>/.
"""

import argparse
import json
import subprocess
import sys
from pathlib import Path

# (env, gait, speed m/s, seconds, lateral push N for 0.1 s at t = 3 s or None, measure from s)
CASES = [
    ("minitaur", "trot", 0.3, 10, None, 0),
    ("minitaur", "stand", 0.0, 10, None, 0),
    ("minitaur", "trot", 0.3, 10, 20, 0),
    ("minitaur", "trot", 0.3, 10, -20, 0),
    ("minitaur", "stand", 0.0, 10, 20, 0),
    ("ant", "trot", 0.3, 11, None, 1),
    ("ant", "stand", 0.0, 11, None, 1),
    ("ant", "trot", 0.3, 11, 40, 1),
    ("ant", "trot", 0.3, 11, -40, 1),
    ("walker2d", "walk", 0.5, 10, None, 0),
    ("walker2d", "stand", 0.0, 10, None, 0),
    ("humanoid", "stand", 0.0, 10, None, 0),
    ("humanoid", "stand", 0.0, 10, 40, 0),
    ("humanoid", "stand", 0.0, 10, -40, 0),
    ("humanoid", "walk", 0.3, 10, None, 0),
]


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--bin", default="target/release/centaur")
    ap.add_argument("--only", help="run only this robot's rows")
    ap.add_argument("--mpc-solver", default="structured", help="structured (the default) or clarabel")
    args = ap.parse_args()
    root = Path("/tmp/centaur-closed-loop")
    print("| robot | gait, command | push | survived | mean speed (m/s) | yaw drift (rad) | "
          "drift (m) | max tilt (rad) | tick mean / p99 (µs) | MPC solve (µs) | WBC solve (µs) |")
    print("|---|---|---|---|---:|---:|---:|---:|---:|---:|---:|")
    for n, (env, gait, speed, seconds, push, measure_from) in enumerate(CASES):
        if args.only and env != args.only:
            continue
        out = root / str(n)
        cmd = [args.bin, "control", "--env", env, "--gait", gait, "--speed", str(speed),
               "--seconds", str(seconds), "--measure-from", str(measure_from), "--out", str(out),
               "--mpc-solver", args.mpc_solver]
        if push is not None:
            cmd += ["--push-force", str(push)]
        subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
        s = json.loads((out / "summary.json").read_text())
        push_txt = "—" if push is None else f"{push:+g} N × 0.1 s"
        survived = f"fell at {s['seconds']:.1f} s" if s["fell"] else f"yes, {s['seconds'] - s['measured_from']:.0f} s"
        drift = (s["distance"] ** 2 + s["lateral_drift"] ** 2) ** 0.5
        print(f"| {env} | {gait} {speed:g} m/s | {push_txt} | {survived} | {s['mean_speed']:.3f} | "
              f"{s['yaw_drift']:.3f} | {drift if speed == 0 else abs(s['lateral_drift']):.3f} | "
              f"{s['max_tilt']:.2f} | {s['mean_tick_us']:.0f} / {s['p99_tick_us']:.0f} | "
              f"{s['mean_mpc_solve_us']:.0f} | {s['mean_wbc_solve_us']:.0f} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
