"""Ray: RLlib's PPO runs a Centaur env with two env-runner processes on a local two-node
Ray cluster, and a sweep run as Ray tasks equals the same sweep run by `centaur sweep`
(needs ray[rllib] and torch: `tools/python_tests.sh`)."""

import importlib.util
import json
import math
from pathlib import Path

import pytest

ray = pytest.importorskip("ray")
pytest.importorskip("ray.rllib")

import centaur  # noqa: E402
import centaur.ray  # noqa: E402

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "rllib_ppo.py"

GRID = """
env = "pendulum"
algo = "ppo"
steps = 1024
eval_episodes = 2

[base]
n_steps = 256
batch_size = 64
n_epochs = 2

[grid]
learning_rate = [3e-4, 1e-3]
"""


@pytest.fixture(scope="module")
def cluster():
    spec = importlib.util.spec_from_file_location("rllib_ppo", EXAMPLE)
    example = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(example)
    with example.local_cluster(port=6391) as address:
        ray.init(address=address)
        try:
            yield example
        finally:
            ray.shutdown()


def test_rllib_ppo_on_a_local_cluster(cluster):
    rows = cluster.train("centaur/Pendulum-v1", iterations=2, runners=2)
    assert rows[-1]["env_steps"] == 4000
    assert all(math.isfinite(r["return_mean"]) for r in rows)
    assert rows[-1]["nodes"] == 2  # head and worker
    assert len(rows[-1]["runner_pids"]) == 2  # two env-runner processes


def test_sweep_as_ray_tasks_equals_centaur_sweep(cluster, tmp_path):
    grid = tmp_path / "grid.toml"
    grid.write_text(GRID)
    table = centaur.ray.sweep(grid, seeds=2, out=tmp_path / "ray")
    assert "learning_rate" in table
    local = centaur._native.sweep(str(grid), 2, str(tmp_path / "local"), jobs=2)
    a = json.loads((tmp_path / "ray" / "sweep.json").read_text())
    b = json.loads((tmp_path / "local" / "sweep.json").read_text())
    finals = lambda s: [p["final_returns"] for p in s["points"]]  # noqa: E731
    assert finals(a) == finals(b) and len(finals(a)) == 2 and all(len(f) == 2 for f in finals(a))
    # resumable: a second call keeps every run
    assert centaur._native.sweep_some(str(grid), 2, str(tmp_path / "ray"), [("p000", 1)]) == 1
    with pytest.raises(centaur.CentaurError, match="no run p007/seed_0"):
        centaur._native.sweep_some(str(grid), 2, str(tmp_path / "ray"), [("p007", 0)])
