//! VecEnv semantics on the Pendulum: auto-reset keeps the final observation of truncated
//! episodes, results do not depend on the thread count, bad actions are refused.

use centaur_gym::pendulum::Pendulum;
use centaur_gym::{Env, EnvError, Rng, VecEnv};

fn pendulums(n: usize, threads: usize) -> VecEnv {
    VecEnv::new((0..n).map(|_| Box::new(Pendulum::new()) as Box<dyn Env>).collect(), threads).unwrap()
}

#[test]
fn auto_reset_keeps_final_observation_of_truncated_episodes() {
    let mut venv = pendulums(2, 1);
    let mut obs = vec![0.0; 6];
    venv.reset(10, &mut obs).unwrap();
    assert_eq!(venv.observations(), Some(&obs[..]));
    let mut out = venv.make_step_buffers();
    // A single pendulum with env 1's seed (10 + 1), driven by the same actions.
    let mut single = Pendulum::new();
    let mut single_obs = [0.0f32; 3];
    single.reset(Some(11), &mut single_obs).unwrap();
    let mut single_return = 0.0;
    for t in 1..=200 {
        let a = [0.5f32, 0.5];
        venv.step(&a, &mut out).unwrap();
        let s = single.step(&a[1..], &mut single_obs).unwrap();
        single_return += s.reward;
        assert_eq!(out.rewards[1], s.reward);
        assert_eq!(out.truncated, vec![t == 200; 2]);
        assert_eq!(out.terminated, vec![false; 2]);
        if t < 200 {
            assert_eq!(&out.obs[3..], &single_obs[..]);
            assert!(out.episodes.is_empty());
        }
    }
    // The final observation is the truncated state; `obs` already holds the next episode's
    // first observation (a fresh random state, continuing env 1's stream).
    assert_eq!(&out.final_obs[3..], &single_obs[..]);
    assert_ne!(&out.obs[3..], &single_obs[..]);
    single.reset(None, &mut single_obs).unwrap();
    assert_eq!(&out.obs[3..], &single_obs[..]);
    assert_eq!(venv.observations(), Some(&out.obs[..]));
    assert_eq!(out.episodes.len(), 2);
    let rec = out.episodes[1];
    assert_eq!((rec.env, rec.length, rec.terminated), (1, 200, false));
    assert!((rec.ret - single_return).abs() < 1e-9);
    // The episode counters restart.
    venv.step(&[0.0, 0.0], &mut out).unwrap();
    assert!(out.episodes.is_empty());
}

fn run(threads: usize) -> (Vec<u32>, Vec<u64>) {
    let mut venv = pendulums(5, threads);
    let mut obs = vec![0.0; 15];
    venv.reset(3, &mut obs).unwrap();
    let mut out = venv.make_step_buffers();
    let mut rng = Rng::seed_from_u64(9);
    let (mut o, mut r) = (Vec::new(), Vec::new());
    let mut actions = vec![0.0f32; 5];
    for _ in 0..450 {
        actions.iter_mut().for_each(|a| *a = rng.range(-3.0, 3.0) as f32);
        venv.step(&actions, &mut out).unwrap();
        o.extend(out.obs.iter().chain(&out.final_obs).map(|x| x.to_bits()));
        r.extend(out.rewards.iter().map(|x| x.to_bits()));
        r.extend(out.episodes.iter().map(|e| e.ret.to_bits()));
    }
    (o, r)
}

#[test]
fn one_and_two_threads_give_identical_results() {
    let a = run(1);
    let b = run(2);
    assert!(a.0 == b.0 && a.1 == b.1);
}

#[test]
fn bad_actions_are_refused() {
    let mut venv = pendulums(2, 2);
    let mut out = venv.make_step_buffers();
    // Stepping before reset: every env needs a reset.
    assert!(matches!(venv.step(&[0.0, 0.0], &mut out), Err(EnvError::NeedsReset)));
    let mut obs = vec![0.0; 6];
    venv.reset(0, &mut obs).unwrap();
    let err = venv.step(&[0.0, f32::NAN], &mut out).unwrap_err();
    assert!(matches!(err, EnvError::NonFiniteAction { index: 0, .. }), "{err}");
    assert_eq!(venv.observations(), None);
    assert!(matches!(VecEnv::new(Vec::new(), 1), Err(EnvError::Empty)));
}

#[test]
#[should_panic(expected = "VecEnv::step: 3 actions, expected 2 × 1")]
fn wrong_action_buffer_length_is_a_programming_error() {
    let mut venv = pendulums(2, 1);
    let mut out = venv.make_step_buffers();
    let mut obs = vec![0.0; 6];
    venv.reset(0, &mut obs).unwrap();
    let _ = venv.step(&[0.0; 3], &mut out);
}
