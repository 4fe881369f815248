#!/usr/bin/env python3
"""Runs `centaur control` over robots × gaits × speeds × seeds and prints the README's
controller tables (Markdown): survival counts, mean speed, yaw drift, tilt, cost of
transport (mechanical energy / (m g distance) over the measured time) and tick times, each
over the seeds.

    cargo build --release --features cli --bin centaur
    python3 tools/closed_loop_table.py [--seeds 5] [--only minitaur] [--table speed|push|noise|turn|steps|unrated|all] [--drawn-motor]

Every run is 10 s after a 1 s ramp (`--measure-from 1`, 11 s simulated), with the env's
randomisation as in training (each reset seed draws it). A row passes when no seed falls,
every seed's mean speed is within 15 % of the command and every yaw drift is below 0.2 rad
(turning rows: the mean yaw rate and the speed along the heading within 15 %).
`--table unrated` runs gaits and speeds the presets do not offer (`centaur control
--unrated`) to show why. The Minitaur's controller is told the nominal motor (the default since
2026-11-27); `--drawn-motor` runs its rows with the controller told the motor drawn at reset, as
every figure before then was measured (`centaur control --drawn-motor`). No dependencies beyond the standard library; each run writes
/tmp/centaur-closed-loop/<n>/.
"""

import argparse
import json
import subprocess
import sys
from pathlib import Path

# Offered gaits and the speeds of the targets, per robot.
SPEED_ROWS = [
    ("minitaur", "stand", 0.0),
    ("minitaur", "trot", 0.3),
    ("minitaur", "trot", 0.6),
    ("minitaur", "trot", 1.0),
    ("minitaur", "trot", 1.5),
    ("minitaur", "trot", 2.0),
    ("minitaur", "trot", 2.5),
    ("minitaur", "walk", 0.3),
    ("minitaur", "walk", 0.5),
    ("minitaur", "bound", 0.3),
    ("minitaur", "bound", 1.0),
    ("minitaur", "bound", 1.5),
    ("minitaur", "bound", 2.0),
    ("minitaur", "bound", 2.5),
    ("minitaur", "pronk", 0.3),
    ("minitaur", "pronk", 1.0),
    ("minitaur", "pronk", 2.0),
    ("ant", "stand", 0.0),
    ("ant", "trot", 0.3),
    ("ant", "trot", 0.6),
    ("ant", "trot", 1.0),
    ("ant", "trot", 1.2),
    ("ant", "walk", 0.3),
    ("walker2d", "stand", 0.0),
    ("walker2d", "walk", 0.5),
    ("walker2d", "walk", 1.0),
    ("humanoid", "stand", 0.0),
    ("humanoid", "walk", 0.3),
    ("humanoid", "walk", 0.4),
    ("humanoid", "walk", 0.5),
]
# Targets the presets do not rate (run with --unrated): why they are not offered.
UNRATED_ROWS = [
    ("ant", "trot", 1.5),
    ("ant", "walk", 0.5),
    ("walker2d", "walk", 1.25),
    ("walker2d", "walk", 1.5),
    ("humanoid", "walk", 0.6),
    ("humanoid", "walk", 0.7),
    ("minitaur", "trot", 2.75),
    ("minitaur", "bound", 3.0),
    ("minitaur", "bound", 3.5),
    ("minitaur", "pronk", 2.5),
    ("minitaur", "gallop", 1.0),
    ("minitaur", "pace", 1.0),
    ("ant", "pace", 0.3),
    ("ant", "bound", 0.3),
    ("ant", "gallop", 0.3),
]
# (robot, gait, speed, push N for 0.1 s at t = 3 s[, axis: "y" lateral (default) or "x" fore-aft])
PUSH_ROWS = [
    ("minitaur", "trot", 0.3, 10), ("minitaur", "trot", 0.3, -10),
    ("minitaur", "trot", 0.3, 20), ("minitaur", "trot", 0.3, -20),
    ("minitaur", "trot", 1.0, 10), ("minitaur", "trot", 1.0, -10),
    ("minitaur", "trot", 1.0, 20), ("minitaur", "trot", 1.0, -20),
    ("minitaur", "trot", 2.0, 20), ("minitaur", "trot", 2.0, -20),
    ("minitaur", "stand", 0.0, 20), ("minitaur", "stand", 0.0, -20),
    ("minitaur", "bound", 0.3, 20), ("minitaur", "bound", 0.3, -20),
    ("minitaur", "bound", 1.0, 40), ("minitaur", "bound", 1.0, -40),
    ("minitaur", "bound", 2.0, 40), ("minitaur", "bound", 2.0, -40),
    ("minitaur", "bound", 2.5, 20), ("minitaur", "bound", 2.5, -20),
    # Above the bound's 2.5 m/s rating (run with --unrated): why it is rated 2.5.
    ("minitaur", "bound", 3.0, 20), ("minitaur", "bound", 3.0, -20),
    ("ant", "trot", 0.3, 40), ("ant", "trot", 0.3, -40),
    ("ant", "trot", 1.0, 40), ("ant", "trot", 1.0, -40),
    ("humanoid", "stand", 0.0, 40), ("humanoid", "stand", 0.0, -40),
    ("humanoid", "walk", 0.3, 40), ("humanoid", "walk", 0.3, -40),
    ("humanoid", "walk", 0.5, 40), ("humanoid", "walk", 0.5, -40),
    # Above the walk's 0.5 m/s rating (run with --unrated): why it is rated 0.5.
    ("humanoid", "walk", 0.6, 40), ("humanoid", "walk", 0.6, -40),
    # The planar Walker2d takes fore-aft pushes only (`--push-axis x`).
    ("walker2d", "walk", 0.5, 40, "x"), ("walker2d", "walk", 0.5, -40, "x"),
    ("walker2d", "walk", 1.0, 40, "x"), ("walker2d", "walk", 1.0, -40, "x"),
    ("walker2d", "walk", 0.5, 100, "x"), ("walker2d", "walk", 0.5, -100, "x"),
    ("walker2d", "walk", 1.0, 100, "x"), ("walker2d", "walk", 1.0, -100, "x"),
]
# (robot, gait, speed, action noise as a fraction of each entry's half-range)
NOISE_ROWS = [
    ("minitaur", "trot", 0.3, 0.1),
    ("minitaur", "trot", 1.0, 0.1),
    ("minitaur", "trot", 2.0, 0.1),
    ("minitaur", "bound", 1.0, 0.1),
    ("minitaur", "bound", 2.0, 0.1),
    ("minitaur", "bound", 2.5, 0.1),
    ("ant", "trot", 0.3, 0.1),
    ("ant", "trot", 0.6, 0.1),
    ("ant", "trot", 1.0, 0.1),
]
# (robot, gait, speed, yaw rate rad/s)
TURN_ROWS = [
    ("ant", "trot", 0.3, 0.5), ("ant", "trot", 0.3, -0.5),
    ("ant", "trot", 1.0, 0.5), ("ant", "trot", 1.0, -0.5),
    ("minitaur", "trot", 0.3, 0.3), ("minitaur", "trot", 0.3, -0.3),
    ("minitaur", "trot", 0.3, 0.5), ("minitaur", "trot", 0.3, -0.5),
    ("minitaur", "trot", 0.5, 0.3), ("minitaur", "trot", 0.5, -0.3),
    ("minitaur", "trot", 0.5, 0.5), ("minitaur", "trot", 0.5, -0.5),
    ("minitaur", "trot", 0.6, 0.3), ("minitaur", "trot", 0.6, -0.3),
    ("minitaur", "trot", 0.6, 0.5), ("minitaur", "trot", 0.6, -0.5),
    ("minitaur", "bound", 0.3, 0.5), ("minitaur", "bound", 0.3, -0.5),
    ("minitaur", "bound", 0.6, 0.5), ("minitaur", "bound", 0.6, -0.5),
    ("minitaur", "bound", 1.0, 0.5), ("minitaur", "bound", 1.0, -0.5),
    ("minitaur", "bound", 1.2, 0.3), ("minitaur", "bound", 1.2, -0.3),
    ("ant", "trot", 0.6, 0.5), ("ant", "trot", 0.6, -0.5),
    ("ant", "walk", 0.3, 0.5), ("ant", "walk", 0.3, -0.5),
    ("humanoid", "walk", 0.3, 0.3), ("humanoid", "walk", 0.3, -0.3),
    ("humanoid", "walk", 0.3, 0.5), ("humanoid", "walk", 0.3, -0.5),
    ("humanoid", "walk", 0.4, 0.5), ("humanoid", "walk", 0.4, -0.5),
    ("humanoid", "walk", 0.5, 0.3), ("humanoid", "walk", 0.5, -0.3),
]
# Turning the presets do not rate (run with --unrated; `GaitOffer::turning`): why.
UNRATED_TURN_ROWS = [
    ("minitaur", "trot", 1.0, 0.5), ("minitaur", "trot", 1.0, -0.5),
    ("minitaur", "walk", 0.3, 0.3), ("minitaur", "walk", 0.3, -0.3),
    ("minitaur", "bound", 1.5, 0.5), ("minitaur", "bound", 1.5, -0.5),
    ("minitaur", "pronk", 1.0, 0.5), ("minitaur", "pronk", 1.0, -0.5),
    ("ant", "trot", 1.2, 0.5), ("ant", "trot", 1.2, -0.5),
    ("humanoid", "walk", 0.5, 0.5), ("humanoid", "walk", 0.5, -0.5),
]
# Push rows above the preset's rating.
UNRATED_PUSH_ROWS = {("humanoid", "walk", 0.6), ("minitaur", "bound", 3.0)}
# (robot, gait, schedule)
STEP_ROWS = [("minitaur", "trot", "0:0,1:1.5,6:0"), ("minitaur", "trot", "0:0,1:2.5,6:0"), ("minitaur", "trot", "0:0,1:2.5,6:1.0"), ("minitaur", "trot", "0:0,1:1.0,4:0.3,7:0"), ("minitaur", "bound", "0:0,1:2.5,6:0"), ("humanoid", "walk", "0:0,1:0.5,6:0")]


class Runner:
    def __init__(self, binary: str, seeds: int, minitaur_extra=()):
        self.binary = binary
        self.seeds = seeds
        self.minitaur_extra = tuple(minitaur_extra)
        self.n = 0
        self.root = Path("/tmp/centaur-closed-loop")

    def run(self, env, gait, speed, extra=(), seed=0, seconds=11.0, measure_from=1.0):
        out = self.root / str(self.n)
        self.n += 1
        cmd = [self.binary, "control", "--env", env, "--gait", gait, "--speed", str(speed),
               "--seconds", str(seconds), "--measure-from", str(measure_from), "--seed", str(seed),
               "--out", str(out), *extra, *(self.minitaur_extra if env.startswith("minitaur") else ())]
        subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
        return json.loads((out / "summary.json").read_text())

    def seeds_of(self, *args, **kw):
        return [self.run(*args, seed=s, **kw) for s in range(self.seeds)]


def rng(xs, fmt="{:.3f}"):
    lo, hi = fmt.format(min(xs)), fmt.format(max(xs))
    return lo if lo == hi or max(xs) - min(xs) < 5e-4 else f"{lo}–{hi}"


def survived(runs):
    falls = [r["seconds"] for r in runs if r["fell"]]
    txt = f"{len(runs) - len(falls)}/{len(runs)}"
    if falls:
        txt += " (fell at " + ", ".join(f"{t:.1f}" for t in falls) + " s)"
    return txt


def speed_ok(runs, v):
    if any(r["fell"] for r in runs):
        return False
    if v == 0.0:
        return all(abs(r["mean_speed"]) < 0.05 for r in runs)
    return all(abs(r["mean_speed"] - v) <= 0.15 * abs(v) for r in runs)


def cot(runs):
    # Cost of transport over the measured time (`ControlSummary::cost_of_transport`):
    # energy / (m g distance); "—" while standing.
    xs = [r["cost_of_transport"] for r in runs if r.get("cost_of_transport") is not None]
    return rng(xs, "{:.2f}") if xs and len(xs) == len(runs) else "—"


def speed_table(runner, rows, extra=()):
    print("| robot | gait, command | survived | mean speed (m/s) | yaw drift (rad) | max tilt (rad) | "
          "cost of transport | tick mean / p99 (µs) | MPC solve (µs) | meets the target |")
    print("|---|---|---|---:|---:|---:|---:|---:|---:|---|")
    for env, gait, speed in rows:
        runs = runner.seeds_of(env, gait, speed, extra=extra)
        ok = speed_ok(runs, speed) and all(r["yaw_drift"] < 0.2 for r in runs)
        print(f"| {env} | {gait} {speed:g} m/s | {survived(runs)} | {rng([r['mean_speed'] for r in runs])} | "
              f"{rng([r['yaw_drift'] for r in runs])} | {rng([r['max_tilt'] for r in runs], '{:.2f}')} | {cot(runs)} | "
              f"{sum(r['mean_tick_us'] for r in runs) / len(runs):.0f} / {max(r['p99_tick_us'] for r in runs):.0f} | "
              f"{sum(r['mean_mpc_solve_us'] for r in runs) / len(runs):.0f} | {'yes' if ok else '**no**'} |")
        sys.stdout.flush()


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--bin", default="target/release/centaur")
    ap.add_argument("--seeds", type=int, default=5)
    ap.add_argument("--only", help="run only this robot's rows")
    ap.add_argument("--table", default="all", choices=["speed", "push", "noise", "turn", "steps", "unrated", "all"])
    ap.add_argument("--drawn-motor", action="store_true",
                    help="Minitaur rows only: the controller's torques become actions through the motor drawn at reset "
                         "(the default until 2026-11-27)")
    args = ap.parse_args()
    r = Runner(args.bin, args.seeds, minitaur_extra=("--drawn-motor",) if args.drawn_motor else ())
    pick = lambda rows: [row for row in rows if not args.only or row[0] == args.only]
    want = lambda t: args.table in (t, "all")
    print(f"Seeds 0–{args.seeds - 1}; 10 s after a 1 s ramp.\n")
    if want("speed"):
        print("### Offered gaits and speeds\n")
        speed_table(r, pick(SPEED_ROWS))
        print()
    if want("unrated"):
        print("### Not offered (`--unrated`)\n")
        speed_table(r, pick(UNRATED_ROWS), extra=("--unrated",))
        print()
    if want("push"):
        print("### Pushes (0.1 s at t = 3 s; lateral unless marked along x)\n")
        print("| robot | gait, command | push | survived | mean speed (m/s) | max tilt (rad) |")
        print("|---|---|---|---|---:|---:|")
        for env, gait, speed, f, *axis in pick(PUSH_ROWS):
            axis = axis[0] if axis else "y"
            unrated = ("--unrated",) if (env, gait, speed) in UNRATED_PUSH_ROWS else ()
            runs = r.seeds_of(env, gait, speed, extra=("--push-force", str(f), "--push-axis", axis) + unrated)
            along = " along x" if axis == "x" else ""
            print(f"| {env} | {gait} {speed:g} m/s | {f:+g} N{along} × 0.1 s ({abs(f) * 0.1:g} N·s) | {survived(runs)} | "
                  f"{rng([x['mean_speed'] for x in runs])} | {rng([x['max_tilt'] for x in runs], '{:.2f}')} |")
            sys.stdout.flush()
        print()
    if want("noise"):
        print("### Gaussian action noise every step (fraction of each action's half-range)\n")
        print("| robot | gait, command | noise | survived | mean speed (m/s) | yaw drift (rad) |")
        print("|---|---|---|---|---:|---:|")
        for env, gait, speed, sigma in pick(NOISE_ROWS):
            extra = ("--action-noise", str(sigma)) + (("--unrated",) if env == "ant" and speed > 0.3 else ())
            runs = r.seeds_of(env, gait, speed, extra=extra)
            print(f"| {env} | {gait} {speed:g} m/s | {sigma:g} | {survived(runs)} | "
                  f"{rng([x['mean_speed'] for x in runs])} | {rng([x['yaw_drift'] for x in runs])} |")
            sys.stdout.flush()
        print()
    if want("turn"):
        print("### Turning (yaw-rate command)\n")
        print("| robot | gait, command | yaw rate | survived | mean yaw rate (rad/s) | speed along the heading (m/s) | meets the target |")
        print("|---|---|---|---|---:|---:|---|")
        rows = [(row, ()) for row in pick(TURN_ROWS)] + [(row, ("--unrated",)) for row in pick(UNRATED_TURN_ROWS)]
        for (env, gait, speed, w), unrated in rows:
            runs = r.seeds_of(env, gait, speed, extra=("--yaw-rate", str(w), *unrated))
            ok = not any(x["fell"] for x in runs) and all(
                abs(x["mean_yaw_rate"] - w) <= 0.15 * abs(w) and abs(x["mean_forward_speed"] - speed) <= 0.15 * speed
                for x in runs)
            label = f"{gait} {speed:g} m/s" + (" (not rated)" if unrated else "")
            print(f"| {env} | {label} | {w:+g} rad/s | {survived(runs)} | "
                  f"{rng([x['mean_yaw_rate'] for x in runs])} | {rng([x['mean_forward_speed'] for x in runs])} | "
                  f"{'yes' if ok else '**no**'} |")
            sys.stdout.flush()
        print()
    if want("steps"):
        print("### Speed steps within one run (from t = 0, 10 s)\n")
        print("| robot | gait | schedule (s:m/s) | survived | mean speed per segment (m/s) |")
        print("|---|---|---|---|---|")
        for env, gait, sched in pick(STEP_ROWS):
            runs = r.seeds_of(env, gait, 0.0, extra=("--speed-schedule", sched), seconds=10.0, measure_from=0.0)
            n = len(runs[0]["segments"])
            segs = " · ".join(rng([x["segments"][i]["mean_speed"] for x in runs if len(x["segments"]) > i])
                              for i in range(n))
            print(f"| {env} | {gait} | {sched} | {survived(runs)} | {segs} |")
            sys.stdout.flush()
        print()
    return 0


if __name__ == "__main__":
    sys.exit(main())
