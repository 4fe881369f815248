"""The bindings return exactly what the Rust calls return (`rust_reference.json`, checked
against Rust by `cargo test --test python_reference`)."""

import gymnasium as gym
import numpy as np
import pytest

import centaur
from conftest import DATA, REPO


def load(source):
    if "robot" in source:
        return centaur.Model.for_robot(source["robot"])
    return centaur.Model.from_urdf(str(REPO / source["urdf"]), floating_base=source["floating_base"])


def exact(got, expected):
    np.testing.assert_array_equal(np.asarray(got), np.asarray(expected, dtype=np.asarray(got).dtype))


@pytest.mark.parametrize("index", range(3))
def test_dynamics_equal_rust(reference, index):
    r = reference["dynamics"][index]
    m = load(r["source"])
    assert (m.nq, m.nv) == (r["nq"], r["nv"])
    q, v, a = (np.array(r[k]) for k in ("q", "v", "a"))
    exact(m.rnea(q, v, a), r["rnea"])
    exact(m.aba(q, v, np.array(r["rnea"])), r["aba"])
    exact(m.crba(q), r["crba"])
    exact(m.nonlinear_effects(q, v), r["nonlinear_effects"])
    exact(m.gravity_torques(q), r["gravity_torques"])
    exact(m.center_of_mass(q), r["center_of_mass"])
    assert list(m.energy(q, v)) == r["energy"]
    exact(m.frame_placement(q, r["frame"]), r["frame_placement"])
    for rf, j in r["frame_jacobian"].items():
        exact(m.frame_jacobian(q, r["frame"], rf), j)
    exact(m.integrate(q, v), r["integrate"])
    exact(m.difference(q, np.array(r["integrate"])), r["difference"])


def test_controller_equals_rust(reference):
    r = reference["controller"]
    c = centaur.Controller(centaur.Model.for_robot("minitaur"), r["preset"])
    q, v = np.array(r["q"]), np.array(r["v"])
    for tick in r["ticks"]:
        torques, targets, status = c.tick(q, v, tick["t"], forward_velocity=r["forward_velocity"], gait=r["gait"])
        exact(torques, tick["torques"])
        for k in ("tau_ff", "q_des", "kp", "kd"):
            exact(targets[k], tick[k])
        assert status["gait"] == "trot"


def test_policy_equals_rust(reference):
    r = reference["policy"]
    p = centaur.Policy.load(str(DATA / r["checkpoint"]))
    obs = np.array(r["obs"], dtype=np.float32)
    for o, a in zip(obs, r["actions"]):
        exact(p.act(o), a)
    exact(p.act_batch(obs), r["actions"])


def test_env_equals_rust(reference):
    r = reference["env"]
    env = gym.make(r["id"])
    obs, _ = env.reset(seed=r["seed"])
    exact(obs, r["reset_obs"])
    for s in r["steps"]:
        obs, reward, terminated, _, _ = env.step(np.array(s["action"], dtype=np.float32))
        exact(obs, s["obs"])
        assert reward == s["reward"] and terminated == s["terminated"]
