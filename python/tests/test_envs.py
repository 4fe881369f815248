"""The Gymnasium environments: every id passes Gymnasium's checker, options work and are
checked, bad actions are refused."""

import re
import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import centaur
from conftest import REPO

# Gymnasium's checker gives advice these envs do not follow on purpose, like Gymnasium's
# own MuJoCo robots (unbounded observations) and Pendulum (actions in [-2, 2]).
ADVICE = re.compile(
    r"Box observation space (minimum|maximum) value is -?infinity|recommend using a symmetric and normalized space"
)


def checked(env):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        check_env(env.unwrapped)
    other = [str(w.message) for w in caught if not ADVICE.search(str(w.message))]
    assert other == [], other


@pytest.mark.parametrize("env_id", sorted(centaur.ENV_IDS))
def test_check_env_passes(env_id):
    env = gym.make(env_id)
    checked(env)
    assert env.unwrapped.spec.id == env_id


def test_modular_robot_from_a_body_file():
    body = REPO / "assets/modular/snake.json"
    checked(gym.make("centaur/Modular-v0", body=str(body)))
    with pytest.raises(centaur.CentaurError, match="body"):
        gym.make("centaur/Modular-v0")
    with pytest.raises(centaur.CentaurError):
        gym.make("centaur/Modular-v0", body=str(REPO / "no/such/body.json"))


def test_every_registry_name_has_an_id():
    native = set(centaur._native.names()) - {"modular:FILE.json"}
    assert native == set(centaur.ENV_IDS.values())


def test_options_are_the_env_table():
    plain = gym.make("centaur/Minitaur-v0", randomize=False)
    free = gym.make("centaur/Minitaur-v0", randomize=False, energy_weight=0.0)
    plain.reset(seed=0)
    free.reset(seed=0)
    action = np.full(8, 0.3, dtype=np.float32)
    for _ in range(5):
        _, r_plain, _, _, info = plain.step(action)
        _, r_free, _, _, _ = free.step(action)
        # reward = … − energy_weight · energy term (the terms are reported unweighted)
        assert r_free - r_plain == pytest.approx(0.005 * info["reward_terms"]["energy"], rel=1e-9, abs=1e-15)
    assert info["reward_terms"]["energy"] > 0
    assert set(info) == {"reward_terms", "forward_velocity", "energy", "foot_contacts", "unstable"}
    # numpy scalars and tuples are accepted for the typed keys
    gym.make("centaur/Ant-v5", healthy_z_range=(0.2, np.float64(1.0)), healthy_reward=np.float32(5.0))


@pytest.mark.parametrize(
    "options, message",
    [
        ({"healthy_reward": 1.0}, "healthy_reward does not apply to the Minitaur"),
        ({"no_such_key": 1}, "no_such_key"),
        ({"frame_skip": 0}, "frame_skip.*expected 1 to 1000"),
        ({"distance_limit": -1.0}, "distance_limit"),
        ({"latency": float("nan")}, "latency is nan"),
        ({"healthy_z_range": [0.2, float("inf")]}, "healthy_z_range is inf"),
        ({"randomize": "yes"}, "expected a boolean"),
    ],
)
def test_bad_options_are_refused_by_name(options, message):
    with pytest.raises((centaur.CentaurError, ValueError), match=message):
        gym.make("centaur/Minitaur-v0", **options)


@pytest.mark.parametrize("env_id", ["centaur/Minitaur-v0", "centaur/Ant-Residual-v5", "centaur/Pendulum-v1"])
def test_episode_length_follows_gymnasium(env_id):
    length = gym.spec(env_id).max_episode_steps
    assert length == centaur._native.Env(centaur.ENV_IDS[env_id]).describe()[3]
    steps = 7
    for env in (
        gym.make(env_id, max_episode_steps=steps),
        gym.make_vec(env_id, num_envs=1, vectorization_mode="vector_entry_point", max_episode_steps=steps),
    ):
        env.reset(seed=0)
        act = env.action_space.sample() * 0.0
        for k in range(steps):
            _, _, terminated, truncated, _ = env.step(act)
            assert not np.any(terminated)
            assert np.all(truncated) == (k == steps - 1), k
    # the env's own limit is lifted under gymnasium.make's TimeLimit
    env = gym.make(env_id, max_episode_steps=length + 5)
    env.reset(seed=0)
    truncations = [env.step(env.action_space.sample() * 0.0)[3] for _ in range(length + 5)]
    assert truncations.index(True) == length + 4
    with pytest.raises(centaur.CentaurError, match="max_episode_steps must be positive"):
        centaur.CentaurEnv("pendulum", max_episode_steps=0)


def test_bad_calls_are_refused():
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message=".*render_mode='human' that is not in the possible render_modes")
        with pytest.raises(centaur.CentaurError, match="render"):
            gym.make("centaur/Ant-v5", render_mode="human")
    env = gym.make("centaur/Ant-v5").unwrapped
    with pytest.raises(centaur.CentaurError, match="reset"):
        env.step(np.zeros(8, dtype=np.float32))
    env.reset(seed=1)
    with pytest.raises(centaur.CentaurError, match="NaN"):
        env.step(np.full(8, np.nan))
    with pytest.raises(centaur.CentaurError, match="8"):
        env.step(np.zeros(5))
    with pytest.raises(centaur.CentaurError, match="shape"):
        env.step(np.zeros((2, 8)))
    with pytest.raises(centaur.CentaurError, match="options"):
        env.reset(options={"x": 1})
    # the env is still usable after refused calls
    env.step(np.zeros(8))


def test_seeding_follows_gymnasium():
    a, b = gym.make("centaur/Minitaur-v0"), gym.make("centaur/Minitaur-v0")
    oa, _ = a.reset(seed=42)
    ob, _ = b.reset(seed=42)
    np.testing.assert_array_equal(oa, ob)
    acts = [a.action_space.sample() for _ in range(20)]
    for act in acts:
        ra, rb = a.step(act), b.step(act)
        np.testing.assert_array_equal(ra[0], rb[0])
        assert ra[1:4] == rb[1:4]
    # reset(None) continues each env's stream (the same here), seed=s restarts it
    np.testing.assert_array_equal(a.reset()[0], b.reset()[0])
    np.testing.assert_array_equal(a.reset(seed=42)[0], oa)


def test_module_prefix_imports_centaur():
    env = gym.make("centaur:centaur/Hopper-v5")
    assert env.unwrapped.name == "hopper"


def test_a_hybrid_takes_its_learners_residual_preset():
    # Walker2d's residual is bounded at 1.0 for PPO and A2C, at 0.1 for the off-policy
    # learners: the same full-scale action moves the robot differently.
    def after_steps(env_id, vector=False, **kwargs):
        if vector:
            env = gym.make_vec(env_id, num_envs=1, vectorization_mode="vector_entry_point", **kwargs)
        else:
            env = gym.make(env_id, **kwargs)
        env.reset(seed=3)
        shape = env.action_space.shape
        return [env.step(np.ones(shape, dtype=np.float32))[0] for _ in range(5)][-1].reshape(-1)

    walker = "centaur/Walker2d-Residual-v5"
    default, ppo, sac = after_steps(walker), after_steps(walker, learner="ppo"), after_steps(walker, learner="sac")
    np.testing.assert_array_equal(default, ppo)
    np.testing.assert_array_equal(sac, after_steps(walker, learner="td3"))
    np.testing.assert_array_equal(sac, after_steps(walker, vector=True, learner="sac"))
    assert not np.allclose(default, sac)
    # robots whose preset is the same for every learner
    ant = "centaur/Ant-Residual-v5"
    np.testing.assert_array_equal(after_steps(ant), after_steps(ant, learner="sac"))
    with pytest.raises(centaur.CentaurError, match="learner `nope`: expected one of ppo, a2c, sac"):
        gym.make(walker, learner="nope")


def test_a_rising_bound_follows_the_training_samples_it_is_told():
    # Walker2d's PPO preset bounds its residual at 1/30 of 1.0 at the start of training,
    # rising to 1.0 over 100k samples; an environment never told acts at the full bound.
    def after_steps(told, vector=False):
        walker = "centaur/Walker2d-Residual-v5"
        if vector:
            env = gym.make_vec(walker, num_envs=1, vectorization_mode="vector_entry_point")
        else:
            env = gym.make(walker)
        if told is not None:
            (env if vector else env.unwrapped).set_training_samples(told)
        env.reset(seed=3)
        shape = env.action_space.shape
        return [env.step(np.ones(shape, dtype=np.float32))[0] for _ in range(5)][-1].reshape(-1)

    never, start, done = after_steps(None), after_steps(0), after_steps(100_000)
    np.testing.assert_array_equal(never, done)
    assert not np.allclose(never, start)
    np.testing.assert_array_equal(start, after_steps(0, vector=True))
