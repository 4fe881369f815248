"""The numpy bindings: identities of the dynamics, and bad input refused with CentaurError."""

import numpy as np
import pytest

import centaur
from conftest import DATA, REPO

SOLO = str(REPO / "assets/solo12/solo12.urdf")


@pytest.fixture(scope="module")
def solo():
    return centaur.Model.from_urdf(SOLO, floating_base=True)


def random_state(model, seed):
    rng = np.random.default_rng(seed)
    q = model.integrate(model.neutral(), rng.uniform(-0.5, 0.5, model.nv))
    return q, rng.uniform(-1, 1, model.nv), rng.uniform(-1, 1, model.nv)


def test_dynamics_identities(solo):
    q, v, a = random_state(solo, 0)
    tau = solo.rnea(q, v, a)
    np.testing.assert_allclose(solo.aba(q, v, tau), a, atol=1e-9)  # ABA undoes RNEA
    m = solo.crba(q)
    np.testing.assert_allclose(m, m.T, atol=1e-12)
    np.testing.assert_allclose(m @ a + solo.nonlinear_effects(q, v), tau, atol=1e-9)
    np.testing.assert_allclose(solo.nonlinear_effects(q, np.zeros(solo.nv)), solo.gravity_torques(q), atol=1e-12)
    kinetic, _ = solo.energy(q, v)
    assert kinetic == pytest.approx(0.5 * v @ m @ v, rel=1e-10)
    np.testing.assert_allclose(solo.difference(q, solo.integrate(q, v)), v, atol=1e-12)
    assert solo.total_mass == pytest.approx(m[0, 0], rel=1e-12)  # the base's translational inertia


def test_frame_jacobian_is_the_derivative_of_the_placement(solo):
    q, v, _ = random_state(solo, 1)
    j = solo.frame_jacobian(q, "FL_FOOT", "local_world_aligned")
    eps = 1e-6
    p_plus = solo.frame_placement(solo.integrate(q, eps * v), "FL_FOOT")[:3, 3]
    p_minus = solo.frame_placement(solo.integrate(q, -eps * v), "FL_FOOT")[:3, 3]
    np.testing.assert_allclose((p_plus - p_minus) / (2 * eps), j[:3] @ v, atol=1e-7)


def test_models_and_their_errors(tmp_path):
    m = centaur.Model.for_robot("minitaur")
    assert m.nq == m.nv + 1 and m.has_floating_base and "universe" in m.joint_names
    fixed = centaur.Model.from_urdf(str(REPO / "assets/ur5/ur5_robot.urdf"), floating_base=False)
    assert fixed.nq == fixed.nv == 6 and not fixed.has_floating_base
    q = m.neutral()
    with pytest.raises(centaur.CentaurError, match="q has 3 entries, expected"):
        m.rnea(q[:3], np.zeros(m.nv), np.zeros(m.nv))
    with pytest.raises(centaur.CentaurError, match=r"v\[2\] is NaN"):
        m.rnea(q, np.array([0, 0, np.nan] + [0] * (m.nv - 3), dtype=float), np.zeros(m.nv))
    with pytest.raises(centaur.CentaurError, match="no frame `nope`"):
        m.frame_placement(q, "nope")
    with pytest.raises(centaur.CentaurError, match="reference frame"):
        m.frame_jacobian(q, m.frame_names[-1], "sideways")
    broken = tmp_path / "broken.urdf"
    broken.write_text("<robot name='x'><link name='a'>")
    with pytest.raises(centaur.CentaurError):
        centaur.Model.from_urdf(str(broken))
    with pytest.raises(centaur.CentaurError):
        centaur.Model.from_urdf(str(tmp_path / "missing.urdf"))
    with pytest.raises(centaur.CentaurError, match="unknown environment"):
        centaur.Model.for_robot("cheetah")


def test_controller_errors():
    model = centaur.Model.for_robot("minitaur")
    c = centaur.Controller(model, "minitaur")
    q, v = c.nominal(), np.zeros(model.nv)
    torques, targets, status = c.tick(q, v, 0.0, forward_velocity=0.3)
    assert torques.shape == (len(c.joint_names),) and np.isfinite(torques).all()
    assert status["fallback"] == "None" and len(status["contact"]) == len(c.contact_frames)
    with pytest.raises(centaur.CentaurError, match="offers stand, trot"):
        c.tick(q, v, 0.01, gait="gallop")
    with pytest.raises(centaur.CentaurError, match="unknown gait"):
        c.tick(q, v, 0.01, gait="moonwalk")
    with pytest.raises(centaur.CentaurError, match="forward_velocity is NaN"):
        c.tick(q, v, 0.01, forward_velocity=float("nan"))
    with pytest.raises(centaur.CentaurError, match="contacts has 1 entries"):
        c.tick(q, v, 0.01, contacts=[True])
    # A non-finite state is the controller's documented fallback (posture PD), not an error.
    bad = q.copy()
    bad[0] = np.nan
    torques, _, status = c.tick(bad, v, 0.02)
    assert status["fallback"] == "PosturePd" and np.isfinite(torques[1:]).all()
    # The gait clock's rate: followed at its slew (2 per second), refused when not a rate.
    assert c.gait_rate == 1.0
    c.set_gait_rate(1.5)
    for k in range(3, 40):
        c.tick(q, v, 0.01 * k, forward_velocity=0.3)
    assert c.gait_rate == pytest.approx(1.5)
    for bad in (float("nan"), 0.0, -1.0, 0.2, 4.5):
        with pytest.raises(centaur.CentaurError, match="gait rate"):
            c.set_gait_rate(bad)
    c.reset()
    assert c.gait_rate == 1.0
    # The stance fractions' shift: followed at its slew (1 per second), refused out of range.
    assert c.gait_duty_shift == 0.0
    c.set_gait_duty_shift(-0.1)
    for k in range(0, 40):
        c.tick(q, v, 0.01 * k, forward_velocity=0.3)
    assert c.gait_duty_shift == pytest.approx(-0.1)
    for bad in (float("nan"), 0.31, -0.5):
        with pytest.raises(centaur.CentaurError, match="duty shift"):
            c.set_gait_duty_shift(bad)
    c.reset()
    assert c.gait_duty_shift == 0.0
    # The swing apex's scale: taken by the next swings, refused out of range.
    assert c.swing_height_scale == 1.0
    c.set_swing_height_scale(0.5)
    assert c.swing_height_scale == 0.5
    for bad in (float("nan"), 0.2, 1.8):
        with pytest.raises(centaur.CentaurError, match="swing height scale"):
            c.set_swing_height_scale(bad)
    c.reset()
    assert c.swing_height_scale == 1.0
    # The foothold offset: taken by the next swings, refused out of range.
    assert c.foothold_offset == 0.0
    c.set_foothold_offset(-0.04)
    assert c.foothold_offset == -0.04
    for bad in (float("nan"), 0.11, -0.2):
        with pytest.raises(centaur.CentaurError, match="foothold offset"):
            c.set_foothold_offset(bad)
    c.reset()
    assert c.foothold_offset == 0.0
    with pytest.raises(centaur.CentaurError, match="unknown controller preset"):
        centaur.Controller(model, "cheetah")
    with pytest.raises(centaur.CentaurError):
        centaur.Controller(centaur.Model.for_robot("ant"), "minitaur")


def test_policy_errors(tmp_path):
    p = centaur.Policy.load(str(DATA / "policy_checkpoint"))
    assert (p.obs_dim, p.act_dim) == (3, 1)
    with pytest.raises(centaur.CentaurError, match="obs has 2 entries, expected 3"):
        p.act(np.zeros(2, dtype=np.float32))
    with pytest.raises(centaur.CentaurError, match="each observation has 4 entries"):
        p.act_batch(np.zeros((2, 4), dtype=np.float32))
    corrupt = tmp_path / "checkpoint"
    corrupt.write_bytes((DATA / "policy_checkpoint").read_bytes()[:1000])
    with pytest.raises(centaur.CentaurError):
        centaur.Policy.load(str(corrupt))


def test_a_checkpoint_rebuilds_the_env_it_was_trained_on():
    # A hybrid trained from a spec with two steered parts (10 actions; the preset's has 9):
    # its environment comes from the checkpoint alone, and its policy acts in it.
    path = DATA / "hybrid_spec_checkpoint"
    policy = centaur.Policy.load(str(path))
    env = centaur.CentaurEnv.from_checkpoint(path)
    assert env.name == "minitaur-residual"
    assert env.action_space.shape == (policy.act_dim,) == (10,)
    assert env.observation_space.shape == (policy.obs_dim,)
    preset = centaur.CentaurEnv("minitaur-residual")
    assert preset.action_space.shape == (9,)
    obs, _ = env.reset(seed=0)
    total, steps = 0.0, 0
    for _ in range(50):
        obs, reward, terminated, truncated, _ = env.step(policy.act(obs))
        total, steps = total + reward, steps + 1
        if terminated or truncated:
            break
    assert steps > 0 and np.isfinite(total)
    # A checkpoint that names no environment is refused, saying so.
    with pytest.raises(centaur.CentaurError, match="does not name its environment"):
        centaur.CentaurEnv.from_checkpoint(DATA / "policy_checkpoint")
