"""Training throughput of Centaur's learners against Stable-Baselines3 (1 torch thread), on
the same task, network sizes and hyperparameters, alternating the two (A/B/A/B) because the
machine is shared.

    pip install stable-baselines3 gymnasium mujoco torch
    cargo build --release --example bench_rl
    python tools/rl_side_by_side.py [--rounds 2] [--algos ppo,sac,td3]

Task: Walker2d (Centaur's `walker2d` on Rapier, Gymnasium's Walker2d-v5 on MuJoCo). PPO runs
20,480 steps (10 rollouts of 2048); SAC and TD3 run 6,000 steps with 1,000 random warm-up
steps, and are compared on the rate after warm-up (one gradient step per environment step).
"""
import argparse
import json
import os
import statistics
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
CASES = {"ppo": ("20480", "fps"), "sac": ("6000", "fps_after_learning_starts"),
         "td3": ("6000", "fps_after_learning_starts"), "a2c": ("20480", "fps"),
         "ddpg": ("6000", "fps_after_learning_starts")}


def run(cmd):
    out = subprocess.run(cmd, check=True, capture_output=True, text=True, cwd=ROOT).stdout
    return json.loads(out.strip().splitlines()[-1])


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--rounds", type=int, default=2)
    ap.add_argument("--algos", default="ppo,sac,td3")
    args = ap.parse_args()
    exe = os.path.join(ROOT, "target", "release", "examples", "bench_rl")
    rows = []
    for algo in args.algos.split(","):
        steps, key = CASES[algo]
        ours, sb3 = [], []
        for _ in range(args.rounds):
            ours.append(run([exe, "--env", "walker2d", "--algo", algo, "--steps", steps, "--learning-starts", "1000"])[key])
            sb3.append(run([sys.executable, "tools/sb3_bench.py", "--env", "Walker2d-v5", "--algo", algo, "--steps", steps,
                            "--learning-starts", "1000"])[key])
            print(f"{algo}: centaur {ours[-1]:.0f}, sb3 {sb3[-1]:.0f} steps/s", file=sys.stderr)
        o, s = statistics.median(ours), statistics.median(sb3)
        rows.append((algo, o, s, o / s))
    print("| algorithm | Centaur steps/s | Stable-Baselines3 steps/s | ratio |")
    print("|---|---:|---:|---:|")
    for algo, o, s, r in rows:
        print(f"| {algo} | {o:,.0f} | {s:,.0f} | {r:.1f}× |")
    print(f"\nWalker2d, median of {args.rounds} alternating runs; load average {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
