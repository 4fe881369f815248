"""Ray RLlib's PPO on a Centaur env with several env-runner processes, on a local Ray
cluster of two nodes (head and worker) started on this machine, or on a cluster you
started yourself.

    python python/examples/rllib_ppo.py [--env centaur/Pendulum-v1] [--iterations 10] [--runners 2]
    python python/examples/rllib_ppo.py --address HEAD_IP:6379    # an existing cluster

On a multi-machine cluster: `ray start --head --port=6379` on one machine, `ray start
--address=HEAD_IP:6379` on the others (each with `pip install ./python` done), then this
script with `--address HEAD_IP:6379` and as many `--runners` as the cluster has CPUs to spare.
"""

from __future__ import annotations

import argparse
import contextlib
import subprocess
import sys
import time

import ray
from ray.rllib.algorithms.ppo import PPOConfig

import centaur.ray


@contextlib.contextmanager
def local_cluster(port: int = 6390, cpus_per_node: int = 2):
    """A Ray head and one worker node on this machine (two raylets), stopped on exit."""
    ray_cli = [sys.executable, "-m", "ray.scripts.scripts"]
    address = f"127.0.0.1:{port}"
    common = ["--num-cpus", str(cpus_per_node), "--disable-usage-stats"]
    head = [*ray_cli, "start", "--head", f"--port={port}", "--include-dashboard=false", *common]
    subprocess.run(head, check=True, capture_output=True)
    try:
        subprocess.run([*ray_cli, "start", f"--address={address}", *common], check=True, capture_output=True)
        yield address
    finally:
        subprocess.run([*ray_cli, "stop", "--force"], capture_output=True)


def train(env_id: str, iterations: int, runners: int, seed: int = 0) -> list[dict]:
    """PPO for `iterations` iterations; each row: iteration, env steps, mean episode return."""
    centaur.ray.register_rllib_envs()
    config = (
        PPOConfig()
        .environment(env_id)
        .env_runners(num_env_runners=runners, num_envs_per_env_runner=1, rollout_fragment_length="auto")
        .training(train_batch_size_per_learner=2000, minibatch_size=250, num_epochs=10, lr=1e-3, gamma=0.9)
        .debugging(seed=seed)
    )
    algo = config.build_algo()
    rows = []
    try:
        for i in range(iterations):
            r = algo.train()["env_runners"]
            rows.append({
                "iteration": i + 1,
                "env_steps": r.get("num_env_steps_sampled_lifetime"),
                "return_mean": r.get("episode_return_mean"),
            })
        rows[-1]["nodes"] = len([n for n in ray.nodes() if n["Alive"]])
        rows[-1]["runner_pids"] = sorted(set(algo.env_runner_group.foreach_env_runner(lambda r: __import__("os").getpid(), local_env_runner=False)))
    finally:
        algo.stop()
    return rows


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--env", default="centaur/Pendulum-v1")
    ap.add_argument("--iterations", type=int, default=10)
    ap.add_argument("--runners", type=int, default=2)
    ap.add_argument("--address", help="an existing Ray cluster (default: start a local one)")
    args = ap.parse_args()
    start = time.time()
    with contextlib.nullcontext(args.address) if args.address else local_cluster() as address:
        ray.init(address=address)
        try:
            rows = train(args.env, args.iterations, args.runners)
        finally:
            ray.shutdown()
    for r in rows:
        print(r)
    print(f"{args.env}: PPO, {args.runners} env runners, {time.time() - start:.0f} s")


if __name__ == "__main__":
    main()
