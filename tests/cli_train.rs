//! `centaur train` end to end on the Pendulum: every artefact written, the summary
//! consistent with the checkpoint, bad config keys named; `centaur compare` over two seeds,
//! and the same figures on one thread and on two.

use std::path::{Path, PathBuf};

use centaur_lab::train::{Summary, TrainError, TrainOptions, resume, train};
use centaur_rl::{AlgoKind, MetricsCsv, Policy};

fn out_dir(name: &str) -> PathBuf {
    std::env::temp_dir().join(format!("centaur-cli-{}-{name}", std::process::id()))
}

#[test]
fn train_writes_every_artefact() {
    let out = out_dir("ppo");
    let config = out_dir("ppo.toml");
    std::fs::write(
        &config,
        "n_steps = 256\nbatch_size = 64\nactor_hidden = [32, 32]\ncritic_hidden = [32, 32]\n",
    )
    .unwrap();
    let opts = TrainOptions {
        env: "pendulum".into(),
        algo: AlgoKind::Ppo,
        steps: 2048,
        seed: Some(3),
        out: out.clone(),
        config: Some(config),
        threads: 2,
        n_envs: 2,
        eval_episodes: 10,
        checkpoint_every: 0,
        eval_every: 0,
        overwrite: false,
        spec: None,
    };
    let mut records = 0;
    let s = train(&opts, &mut |_| records += 1).unwrap();
    assert_eq!(records, 4); // 2048 / (256 × 2)
    assert_eq!((s.env.as_str(), s.algo.as_str(), s.seed, s.steps), ("pendulum", "ppo", 3, 2048));
    assert!(s.final_return_mean.is_finite() && s.final_return_std >= 0.0 && s.wall_seconds > 0.0);
    for f in [
        "run.json",
        "metrics.csv",
        "episodes.csv",
        "checkpoint",
        "learning_curve.svg",
        "learning_curve.png",
        "metrics.svg",
        "metrics.png",
        "summary.json",
    ] {
        assert!(out.join(f).is_file(), "{f} missing");
    }
    let csv = std::fs::read_to_string(out.join("metrics.csv")).unwrap();
    assert_eq!(csv.lines().count(), 5);
    assert!(csv.starts_with("update,env_steps,wall_time"));
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    for key in [
        "env",
        "algo",
        "seed",
        "steps",
        "wall_seconds",
        "steps_per_second",
        "final_return_mean",
        "final_return_std",
    ] {
        assert!(json.get(key).is_some(), "summary.json lacks {key}");
    }
    let png = std::fs::read(out.join("learning_curve.png")).unwrap();
    assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n");
    assert!(std::fs::read_to_string(out.join("learning_curve.svg")).unwrap().contains("<svg"));
    // The metric panels: PPO's losses, KL and clip fraction among them.
    let svg = std::fs::read_to_string(out.join("metrics.svg")).unwrap();
    for metric in [
        "policy loss",
        "approx kl",
        "clip fraction",
        "explained variance",
        "entropy",
        "value mean",
        "reward mean",
    ] {
        assert!(svg.contains(metric), "metrics.svg lacks {metric}");
    }
    assert!(!svg.contains("mean q"), "PPO has no Q estimate to plot");
    // The mean state value and the mean per-step reward (the Pendulum's is in [−16.3, 0]).
    for m in MetricsCsv::read(&out.join("metrics.csv")).unwrap() {
        assert!(m.value_mean.is_finite() && (-16.3..=0.0).contains(&m.reward_mean), "{m:?}");
        assert!(m.critic_learning_rate == m.learning_rate && m.learning_rate > 0.0, "{m:?}");
    }
    let policy = Policy::load(&out.join("checkpoint")).unwrap();
    assert_eq!((policy.obs_dim(), policy.act_dim()), (3, 1));
    // The checkpoint resumes as a learner and records its environment.
    let ckpt = centaur_rl::Checkpoint::read(&out.join("checkpoint")).unwrap();
    assert_eq!(ckpt.get_meta::<String>("env").unwrap(), "pendulum");
    let resumed = centaur_rl::learners::load(&out.join("checkpoint")).unwrap();
    assert_eq!((resumed.name(), resumed.steps_done()), ("ppo", 2048));
    // `centaur eval` on the run directory: the Pendulum, as trained, beside the checkpoint.
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_centaur"))
        .args(["eval", "--episodes", "10", "--seed", "1000003", "--checkpoint"])
        .arg(&out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(String::from_utf8_lossy(&o.stdout).contains("| pendulum | 10 |"));
    let eval: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("eval.json")).unwrap()).unwrap();
    // The same episodes as the run's own final evaluation (seeds 1,000,000 + 3 + k).
    assert_eq!(eval["stats"]["return_mean"].as_f64(), Some(s.final_return_mean));
    std::fs::remove_dir_all(&out).unwrap();
}

/// A one-thread, one-env Pendulum run of `steps` with `config`, seed 0, no checkpoints.
fn pendulum_run(algo: AlgoKind, steps: u64, out: PathBuf, config: &Path) -> TrainOptions {
    TrainOptions {
        env: "pendulum".into(),
        algo,
        steps,
        seed: Some(0),
        out,
        config: Some(config.to_path_buf()),
        threads: 1,
        n_envs: 1,
        eval_episodes: 10,
        checkpoint_every: 0,
        eval_every: 0,
        overwrite: false,
        spec: None,
    }
}

#[test]
fn unknown_config_keys_and_bad_values_are_named() {
    let config = out_dir("bad.toml");
    std::fs::write(&config, "learning_rate = 1e-3\nlearnin_starts = 5\n").unwrap();
    let opts = pendulum_run(AlgoKind::Sac, 10, out_dir("bad"), &config);
    match train(&opts, &mut |_| {}) {
        Err(TrainError::Config { message, .. }) => assert!(message.contains("learnin_starts"), "{message}"),
        other => panic!("expected a config error, got {other:?}"),
    }
    std::fs::write(&config, "gamma = 2.0\n").unwrap();
    let e = train(&opts, &mut |_| {}).unwrap_err();
    assert!(e.to_string().contains("gamma"), "{e}");
    let bad_env = TrainOptions { env: "cartpole".into(), config: None, ..opts.clone() };
    assert!(matches!(train(&bad_env, &mut |_| {}), Err(TrainError::Registry(_))));
    // Regression (reliability probe): `--envs 0`, `--threads 0` and `--eval-episodes 0`
    // silently became 1; an endless config file was read forever.
    for (bad, option) in [
        (TrainOptions { n_envs: 0, config: None, ..opts.clone() }, "envs"),
        (TrainOptions { threads: 0, config: None, ..opts.clone() }, "threads"),
        (TrainOptions { eval_episodes: 0, config: None, ..opts.clone() }, "eval-episodes"),
    ] {
        match train(&bad, &mut |_| {}) {
            Err(e @ TrainError::BadOption { .. }) => {
                assert!(e.to_string().starts_with(&format!("--{option} 0")), "{e}")
            }
            other => panic!("{option}: {other:?}"),
        }
    }
    // Evaluations are of checkpoints: --eval-every must be a multiple of --checkpoint-every.
    for (checkpoint_every, eval_every) in [(0, 100), (300, 500)] {
        let bad = TrainOptions { checkpoint_every, eval_every, config: None, ..opts.clone() };
        let e = train(&bad, &mut |_| {}).unwrap_err();
        assert!(e.to_string().contains("--eval-every") && e.to_string().contains("multiple"), "{e}");
    }
    // Each checkpoint starts fresh episodes: a period shorter than one episode per env
    // (the Pendulum's 200 steps, here on 2 envs) would cut every episode (reliability probe).
    let bad = TrainOptions { checkpoint_every: 300, steps: 1000, n_envs: 2, config: None, ..opts.clone() };
    let e = train(&bad, &mut |_| {}).unwrap_err();
    assert!(
        e.to_string().starts_with("--checkpoint-every 300 (150 per env; an episode is 200 steps)"),
        "{e}"
    );
    assert!(!bad.out.exists());
    // One segment (the period at or past the budget) cuts nothing: accepted.
    let single = TrainOptions { checkpoint_every: 300, steps: 200, n_envs: 2, config: None, ..opts.clone() };
    assert!(!matches!(train(&single, &mut |_| {}), Err(TrainError::BadOption { .. })));
    std::fs::remove_dir_all(&single.out).unwrap();
    if std::path::Path::new("/dev/zero").exists() {
        let endless = TrainOptions { config: Some("/dev/zero".into()), ..opts };
        match train(&endless, &mut |_| {}) {
            Err(TrainError::Config { message, .. }) => {
                assert!(message.contains("not a config file"), "{message}")
            }
            other => panic!("{other:?}"),
        }
    }
    assert!(!out_dir("bad").exists(), "a refused run left a directory");
}

/// Small PPO settings on the Pendulum: 512 steps per update with two envs.
fn small_ppo_config(name: &str, extra: &str) -> PathBuf {
    let config = out_dir(name);
    std::fs::write(
        &config,
        format!("n_steps = 256\nbatch_size = 128\nn_epochs = 2\nactor_hidden = [16]\ncritic_hidden = [16]\n{extra}"),
    )
    .unwrap();
    config
}

/// Every deterministic metric of a run directory's rows, as bits.
fn metric_bits(dir: &std::path::Path) -> Vec<Vec<u64>> {
    MetricsCsv::read(&dir.join("metrics.csv")).unwrap().iter().map(|m| m.deterministic_bits()).collect()
}

/// The summary's deterministic fields.
fn summary_bits(dir: &std::path::Path) -> (u64, u64, u64, u64) {
    let s: Summary =
        serde_json::from_str(&std::fs::read_to_string(dir.join("summary.json")).unwrap()).unwrap();
    (s.seed, s.steps, s.final_return_mean.to_bits(), s.final_return_std.to_bits())
}

/// `--eval-every` that the learner's rollout does not divide: each checkpoint that comes
/// due is evaluated, at the steps the rollout ended on (none used to be: the
/// steps done, 4,096 past each 4,000, were never a multiple of it).
#[test]
fn evaluations_come_due_where_the_rollout_does_not_divide_the_interval() {
    let config = small_ppo_config("uneven.toml", "seed = 4\n");
    let out = out_dir("uneven");
    let opts = TrainOptions {
        env: "pendulum".into(),
        algo: AlgoKind::Ppo,
        steps: 12_000,
        seed: None,
        out: out.clone(),
        config: Some(config),
        threads: 1,
        n_envs: 2,
        eval_episodes: 10,
        checkpoint_every: 4_000,
        eval_every: 4_000,
        overwrite: false,
        spec: None,
    };
    let summary = train(&opts, &mut |_| {}).unwrap();
    let evals = centaur_lab::train::read_evaluations(&out.join("evaluations.csv")).unwrap();
    // Rollouts of 2 × 256 = 512 steps: the segments end at 4,096, 8,192 and 12,288.
    let steps: Vec<u64> = evals.iter().map(|e| e.step).collect();
    assert_eq!(steps, [4_096, 8_192, 12_288]);
    assert_eq!(evals.last().unwrap().return_mean, summary.final_return_mean);
    std::fs::remove_dir_all(&out).ok();
}

/// Reliability probe, data loss 1 and 2: a run directory is never reused silently, and a
/// run killed with SIGKILL mid-training resumes (`centaur train --resume`) to the metrics,
/// evaluation and learner state of the uninterrupted run, bit for bit, on another number
/// of threads.
#[test]
fn a_killed_run_resumes_to_the_uninterrupted_result() {
    let config = small_ppo_config("kill.toml", "seed = 11\n");
    let whole = out_dir("kill-whole");
    let opts = TrainOptions {
        env: "pendulum".into(),
        algo: AlgoKind::Ppo,
        steps: 40_960,
        seed: None,
        out: whole.clone(),
        config: Some(config.clone()),
        threads: 1,
        n_envs: 2,
        eval_episodes: 10,
        checkpoint_every: 4096,
        eval_every: 8192,
        overwrite: false,
        spec: None,
    };
    let uninterrupted = train(&opts, &mut |_| {}).unwrap();
    assert_eq!(uninterrupted.seed, 11, "without --seed the config file's seed stands");

    // The same run as a process, killed once it has written its second checkpoint.
    let killed = out_dir("kill-killed");
    let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_centaur"))
        .args(["train", "--env", "pendulum", "--algo", "ppo", "--steps", "40960", "--envs", "2"])
        .args(["--checkpoint-every", "4096", "--eval-every", "8192", "--config"])
        .arg(&config)
        .arg("--out")
        .arg(&killed)
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let ckpt = killed.join("checkpoint");
    let started = std::time::Instant::now();
    loop {
        let steps =
            centaur_rl::Checkpoint::read(&ckpt).ok().and_then(|c| c.get_meta::<u64>("steps_done").ok());
        if steps.is_some_and(|s| s >= 8192) {
            break;
        }
        assert!(child.try_wait().unwrap().is_none(), "the run ended before it could be killed");
        assert!(started.elapsed().as_secs() < 120, "no second checkpoint after 120 s");
        std::thread::sleep(std::time::Duration::from_millis(2));
    }
    child.kill().unwrap(); // SIGKILL
    child.wait().unwrap();
    assert!(!killed.join("summary.json").exists(), "the run finished before the kill");

    // Reusing the directory is refused; --resume continues it on two threads.
    let again = TrainOptions { out: killed.clone(), ..opts.clone() };
    assert!(matches!(train(&again, &mut |_| {}), Err(TrainError::RunExists { file: "run.json", .. })));
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_centaur"))
        .args(["train", "--threads", "2", "--resume"])
        .arg(&killed)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert_eq!(metric_bits(&killed), metric_bits(&whole));
    assert_eq!(summary_bits(&killed), summary_bits(&whole));
    let episodes = |d: &std::path::Path| std::fs::read_to_string(d.join("episodes.csv")).unwrap();
    assert_eq!(episodes(&killed), episodes(&whole), "the episode logs differ after resume");
    // The evaluations every 8,192 steps (the last is the final one), equal after resume.
    let evals =
        |d: &std::path::Path| centaur_lab::train::read_evaluations(&d.join("evaluations.csv")).unwrap();
    let steps: Vec<u64> = evals(&whole).iter().map(|e| e.step).collect();
    assert_eq!(steps, [8192, 16384, 24576, 32768, 40960]);
    assert_eq!(evals(&killed), evals(&whole), "the evaluations differ after resume");
    let last = *evals(&whole).last().unwrap();
    assert_eq!((last.return_mean, last.episodes), (uninterrupted.final_return_mean, 10));
    // 40,960 steps of 200-step Pendulum episodes on 2 envs, cut at every 4,096-step segment:
    // 20 per segment, 10 segments; the last column is the episode's step, in order.
    let log = episodes(&whole);
    assert_eq!(log.lines().count(), 1 + 200, "{}", &log[..200.min(log.len())]);
    let steps: Vec<u64> =
        log.lines().skip(1).map(|l| l.split(',').next().unwrap().parse().unwrap()).collect();
    assert!(steps.windows(2).all(|w| w[0] <= w[1]) && *steps.last().unwrap() <= 40_960);
    let state = |d: &std::path::Path| {
        let mut c = centaur_rl::Checkpoint::read(&d.join("checkpoint")).unwrap();
        for timing in ["wall_time", "run_wall_seconds"] {
            c.meta.remove(timing);
        }
        c.to_bytes()
    };
    assert_eq!(state(&killed), state(&whole), "learner states differ after resume");
    // A finished run resumes to its summary; --overwrite replaces it.
    assert_eq!(resume(&killed, 1, &mut |_| {}).unwrap().final_return_mean, uninterrupted.final_return_mean);
    let replaced = TrainOptions { out: killed.clone(), steps: 1024, overwrite: true, ..opts };
    assert_eq!(train(&replaced, &mut |_| {}).unwrap().steps, 1024);
    for d in [&whole, &killed] {
        std::fs::remove_dir_all(d).unwrap();
    }
}

/// What a kill leaves (the run files as they are mid-training, metrics rows past the last
/// checkpoint included), resumed, equals the uninterrupted run: for an off-policy learner
/// with its replay buffer, and for a run killed before its first checkpoint.
#[test]
fn an_off_policy_run_resumes_from_a_mid_run_copy() {
    let config = out_dir("sac-resume.toml");
    std::fs::write(&config, "learning_starts = 200\nbatch_size = 32\nactor_hidden = [16]\ncritic_hidden = [16]\nlog_interval = 100\n").unwrap();
    let whole = out_dir("sac-whole");
    let copy = out_dir("sac-copy");
    let early = out_dir("sac-early");
    let opts = TrainOptions {
        env: "pendulum".into(),
        algo: AlgoKind::Sac,
        steps: 1500,
        seed: Some(4),
        out: whole.clone(),
        config: Some(config),
        threads: 1,
        n_envs: 1,
        eval_episodes: 10,
        checkpoint_every: 500,
        eval_every: 0,
        overwrite: false,
        spec: None,
    };
    let snapshot = |to: &std::path::Path| {
        std::fs::create_dir_all(to).unwrap();
        for f in ["run.json", "metrics.csv", "episodes.csv", "checkpoint"] {
            if whole.join(f).exists() {
                std::fs::copy(whole.join(f), to.join(f)).unwrap();
            }
        }
    };
    train(&opts, &mut |m| {
        if m.env_steps == 300 {
            snapshot(&early);
        }
        if m.env_steps == 800 {
            snapshot(&copy);
        }
    })
    .unwrap();
    assert!(!early.join("checkpoint").exists() && copy.join("checkpoint").exists());
    for dir in [&copy, &early] {
        resume(dir, 1, &mut |_| {}).unwrap();
        assert_eq!(metric_bits(dir), metric_bits(&whole), "{}", dir.display());
        let log = |d: &std::path::Path| std::fs::read_to_string(d.join("episodes.csv")).unwrap();
        assert_eq!(log(dir), log(&whole), "{}", dir.display());
        assert_eq!(summary_bits(dir), summary_bits(&whole), "{}", dir.display());
    }
    // SAC's metric panels: its Q estimate, Q loss and temperature, none of PPO's.
    let svg = std::fs::read_to_string(whole.join("metrics.svg")).unwrap();
    for metric in ["mean q", "q loss", "alpha", "policy loss", "reward mean"] {
        assert!(svg.contains(metric), "metrics.svg lacks {metric}");
    }
    assert!(!svg.contains("clip fraction") && !svg.contains("approx kl"), "SAC has no PPO metrics");
    for d in [&whole, &copy, &early] {
        std::fs::remove_dir_all(d).unwrap();
    }
}

/// `episodes.csv` holds every finished training episode with its reward terms: on the
/// Minitaur each episode's return is its weighted terms' sum (weights of the run's `[env]`).
#[test]
fn the_episode_log_holds_each_episodes_reward_terms() {
    let config = small_ppo_config(
        "terms.toml",
        "\n[env]\nmax_episode_steps = 40\ndistance_weight = 2.0\nenergy_weight = 0.01\ndrift_weight = 0.5\nshake_weight = 0.25\n",
    );
    let out = out_dir("terms");
    let opts =
        TrainOptions { env: "minitaur".into(), ..pendulum_run(AlgoKind::Ppo, 512, out.clone(), &config) };
    train(&opts, &mut |_| {}).unwrap();
    let text = std::fs::read_to_string(out.join("episodes.csv")).unwrap();
    let mut lines = text.lines();
    assert_eq!(lines.next(), Some("step,env,return,length,terminated,forward,energy,drift,shake"));
    let rows: Vec<Vec<f64>> = lines.map(|l| l.split(',').map(|x| x.parse().unwrap()).collect()).collect();
    assert!(rows.len() >= 512 / 40, "{} episodes", rows.len());
    for r in &rows {
        let weighted = 2.0 * r[5] - 0.01 * r[6] + 0.5 * r[7] + 0.25 * r[8];
        assert!((r[2] - weighted).abs() <= 1e-9 * (1.0 + r[2].abs()), "{r:?}: terms sum to {weighted}");
        assert!(r[3] >= 1.0 && r[3] <= 40.0 && r[6] >= 0.0 && r[7] <= 0.0 && r[8] <= 0.0, "{r:?}");
    }
    std::fs::remove_dir_all(&out).unwrap();
    std::fs::remove_file(&config).unwrap();
}

/// A run records its environment's whole configuration (presets resolved) in `run.json`
/// and the checkpoint; if its name and settings build another environment later (a preset
/// or default changed), a resume is refused and an evaluation too unless asked
/// (`--allow-env-change`), each naming where the two differ.
#[test]
fn a_changed_environment_is_not_taken_for_the_one_trained_on() {
    let config = small_ppo_config("changed.toml", "\n[env]\nmax_episode_steps = 50\n");
    let out = out_dir("changed");
    let opts =
        TrainOptions { checkpoint_every: 256, ..pendulum_run(AlgoKind::Ppo, 512, out.clone(), &config) };
    train(&opts, &mut |_| {}).unwrap();
    let record = centaur_lab::train::read_run_record(&out).unwrap();
    let built = record.env_config.clone().unwrap();
    assert_eq!(built, r#"{"g": 10.0, "max_episode_steps": 50}"#);
    let ckpt_path = out.join("checkpoint");
    let mut ckpt = centaur_rl::Checkpoint::read(&ckpt_path).unwrap();
    assert_eq!(ckpt.get_meta::<String>("env_config").unwrap(), built);
    let eval = |allow_env_change| eval_one_episode(&out, allow_env_change);
    eval(false).unwrap();
    let mut recorded_as = |config: &str| {
        ckpt.set_meta("env_config", config);
        ckpt.write(&ckpt_path).unwrap();
    };
    // A record from before a field existed (here as if `max_episode_steps` were new): the
    // same environment.
    recorded_as(r#"{"g": 10.0}"#);
    eval(false).unwrap();
    // As if the preset had been g = 9.81 when it trained, or had a field it no longer has.
    for (then, says) in [
        (r#"{"g": 9.81, "max_episode_steps": 50}"#, "g: recorded 9.81, today 10.0"),
        (r#"{"g": 10.0, "max_episode_steps": 50, "damping": 0.1}"#, "damping: recorded 0.1, today absent"),
    ] {
        recorded_as(then);
        let e = eval(false).unwrap_err().to_string();
        assert!(e.contains("no longer the environment") && e.contains(says), "{e}");
        eval(true).unwrap();
    }
    let run_json = out.join("run.json");
    let mut run: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&run_json).unwrap()).unwrap();
    run["env_config"] = r#"{"g": 9.81, "max_episode_steps": 50}"#.into();
    std::fs::write(&run_json, run.to_string()).unwrap();
    std::fs::remove_file(out.join("summary.json")).unwrap();
    let e = resume(&out, 1, &mut |_| {}).unwrap_err().to_string();
    assert!(e.contains("not the one the run started with") && e.contains("g: recorded 9.81"), "{e}");
    std::fs::remove_dir_all(&out).unwrap();
    std::fs::remove_file(&config).unwrap();
}

/// Reliability probe, data loss: `summary.json` is written before the plots, so a run whose
/// plotting fails (here a directory stands where `learning_curve.svg` goes) still keeps its
/// summary, and the error is reported, not swallowed.
#[test]
fn the_summary_is_kept_when_plotting_fails() {
    let config = small_ppo_config("plot-fails.toml", "");
    let out = out_dir("plot-fails");
    train(&pendulum_run(AlgoKind::Ppo, 512, out.clone(), &config), &mut |_| {}).unwrap();
    let finished: Summary =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    std::fs::remove_file(out.join("summary.json")).unwrap();
    std::fs::remove_file(out.join("learning_curve.svg")).unwrap();
    std::fs::create_dir(out.join("learning_curve.svg")).unwrap();
    assert!(resume(&out, 1, &mut |_| {}).is_err(), "a failed plot passed unreported");
    let kept: Summary =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    assert_eq!(kept.final_return_mean.to_bits(), finished.final_return_mean.to_bits());
    std::fs::remove_dir_all(&out).unwrap();
    std::fs::remove_file(&config).unwrap();
}

/// `centaur ARGS --config CONFIG --out OUT`.
fn centaur_with(args: &[&str], config: &Path, out: &Path) -> std::process::Output {
    std::process::Command::new(env!("CARGO_BIN_EXE_centaur"))
        .args(args)
        .arg("--config")
        .arg(config)
        .arg("--out")
        .arg(out)
        .output()
        .unwrap()
}

/// `centaur train ARGS --config CONFIG --out OUT`, which must succeed.
fn cli_train(args: &[&str], config: &Path, out: &Path) {
    let o = centaur_with(&[&["train"], args].concat(), config, out);
    assert!(o.status.success(), "{args:?}: {}", String::from_utf8_lossy(&o.stderr));
}

/// `centaur train --env minitaur-residual` starts the hybrid as the controller: before any
/// update, the checkpoint's deterministic policy outputs zero (no residual, no steering)
/// whatever it observes.
#[test]
fn a_hybrid_trained_from_the_command_line_starts_as_the_controller() {
    let config = small_ppo_config("hybrid-start.toml", "\n[env]\nmax_episode_steps = 5\n");
    let out = out_dir("hybrid-start");
    cli_train(&["--env", "minitaur-residual", "--algo", "ppo", "--steps", "0"], &config, &out);
    let mut policy = Policy::load(&out.join("checkpoint")).unwrap();
    let mut rng = centaur_gym::Rng::seed_from_u64(3);
    let mut action = vec![1.0f32; policy.act_dim()];
    for _ in 0..5 {
        let obs: Vec<f32> = (0..policy.obs_dim()).map(|_| rng.normal() as f32).collect();
        policy.act(&obs, &mut action);
        assert!(action.iter().all(|&a| a == 0.0), "{action:?}");
    }
    std::fs::remove_dir_all(&out).unwrap();
    std::fs::remove_file(&config).unwrap();
}

/// `centaur eval` of the run in `out`: one episode, written to `out/eval.json`.
fn eval_one_episode(
    out: &Path,
    allow_env_change: bool,
) -> Result<centaur_lab::eval::EvalReport, centaur_lab::eval::EvalError> {
    centaur_lab::eval::run_eval(&centaur_lab::eval::EvalOptions {
        checkpoint: out.to_path_buf(),
        config: None,
        env: None,
        episodes: 1,
        seed: 0,
        record: None,
        out: Some(out.join("eval.json")),
        allow_env_change,
        fade: None,
    })
}

/// A hybrid is trained on its learner's residual preset and evaluated on the same: Walker2d's
/// residual is bounded at 1.0 for PPO (rising from 1/30 of it, the walk at 0.6 of its
/// period) and at 0.1 for the
/// off-policy learners; the run and the checkpoint record it, and `centaur eval` rebuilds
/// the hybrid from the checkpoint's learner (the other preset would be refused as a changed
/// environment).
#[test]
fn a_hybrid_is_trained_and_evaluated_on_its_learners_preset() {
    let config = out_dir("learner-preset.toml");
    std::fs::write(&config, "[env]\nmax_episode_steps = 5\n").unwrap();
    for (algo, scale, ramp) in
        [(AlgoKind::Sac, 0.1, false), (AlgoKind::Td3, 0.1, false), (AlgoKind::Ppo, 1.0, true)]
    {
        let out = out_dir(&format!("learner-preset-{}", algo.name()));
        let opts = TrainOptions {
            env: "walker2d-residual".into(),
            eval_episodes: 1,
            ..pendulum_run(algo, 0, out.clone(), &config)
        };
        train(&opts, &mut |_| {}).unwrap();
        let record = centaur_lab::train::read_run_record(&out).unwrap();
        let built: serde_json::Value = serde_json::from_str(record.env_config.as_deref().unwrap()).unwrap();
        assert_eq!(built["residual"]["scale"], serde_json::json!([scale]), "{}", algo.name());
        assert_eq!(built["residual"].get("bound_ramp").is_some(), ramp, "{}", algo.name());
        // PPO's walk runs at 0.6 of its period, the off-policy learners' on its own.
        let period = if ramp { serde_json::json!(0.6) } else { serde_json::Value::Null };
        assert_eq!(built["residual"]["period_scale"], period, "{}", algo.name());
        let report = eval_one_episode(&out, false);
        assert!(report.is_ok(), "{}: {}", algo.name(), report.unwrap_err());
        std::fs::remove_dir_all(&out).unwrap();
    }
    std::fs::remove_file(&config).unwrap();
}

/// `--seed` given on the command line overrides the config file's `seed` (without it the
/// file's stands: `a_killed_run_resumes_to_the_uninterrupted_result`).
#[test]
fn an_explicit_seed_overrides_the_config_files() {
    let config = small_ppo_config("seeded.toml", "seed = 11\n");
    let out = out_dir("seeded");
    cli_train(&["--env", "pendulum", "--algo", "ppo", "--steps", "512", "--seed", "5"], &config, &out);
    assert_eq!(summary_bits(&out).0, 5);
    let run: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("run.json")).unwrap()).unwrap();
    assert_eq!(run["seed"].as_u64(), Some(5));
    std::fs::remove_dir_all(&out).unwrap();
    std::fs::remove_file(&config).unwrap();
}

/// `centaur compare` takes a run file's `[env]` table too: both agents train on it and all
/// three are evaluated on it (here 30-step episodes); the record keeps it, and the studies on
/// the preset env (`centaur robustness`) refuse such a run.
#[test]
fn compare_takes_the_env_table_of_its_run_file() {
    let out = out_dir("compare-env");
    let config = out_dir("compare-env.toml");
    std::fs::write(&config, "n_steps = 64\nbatch_size = 64\nn_epochs = 1\n[env]\nmax_episode_steps = 30\n")
        .unwrap();
    let o = compare_minitaur_ppo(&["--seeds", "1", "--steps", "64", "--eval-episodes", "1"], &config, &out);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let seed_0 = out.join("seed_0");
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(seed_0.join("summary.json")).unwrap()).unwrap();
    for agent in ["hybrid", "pure_rl", "controller"] {
        let length = summary[agent]["length_mean"].as_f64().unwrap();
        assert!(length <= 30.0, "{agent}: {length}-step episodes");
    }
    let record = std::fs::read_to_string(seed_0.join("experiment.json")).unwrap();
    assert!(record.contains("\"max_episode_steps\": 30"), "{record}");
    let o = robustness(&seed_0, &[]);
    assert!(!o.status.success());
    assert!(
        String::from_utf8_lossy(&o.stderr)
            .contains("trained with [env] settings that change the task (max_episode_steps)")
    );
    // A key the robot does not have: refused before anything is written.
    std::fs::write(&config, "n_steps = 64\n[env]\nhealthy_reward = 1.0\n").unwrap();
    std::fs::remove_dir_all(&out).unwrap();
    let o = compare_minitaur_ppo(&["--seeds", "1", "--steps", "64"], &config, &out);
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("healthy_reward does not apply"));
    assert!(!out.join("seed_0").exists());
    let _ = std::fs::remove_dir_all(&out);
    std::fs::remove_file(&config).unwrap();
}

/// A run whose agents observed the body state (`[env] observe_body_state = true`) is taken by
/// the robustness study, which gives them that observation (without it the policies would not
/// fit the preset env's and the study would refuse them).
#[test]
fn the_robustness_study_takes_a_run_that_observed_the_body_state() {
    let out = out_dir("compare-body-state");
    let config = out_dir("compare-body-state.toml");
    std::fs::write(
        &config,
        "n_steps = 64\nbatch_size = 64\nn_epochs = 1\n[env]\nobserve_body_state = true\n",
    )
    .unwrap();
    let o = compare_minitaur_ppo(&["--seeds", "1", "--steps", "64", "--eval-episodes", "1"], &config, &out);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let seed_0 = out.join("seed_0");
    let o = robustness(&seed_0, &[]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let rows: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(seed_0.join("robustness.json")).unwrap()).unwrap();
    assert_eq!(rows.as_array().map(Vec::len), Some(10), "{rows}");
    let _ = std::fs::remove_dir_all(&out);
    std::fs::remove_file(&config).unwrap();
}

/// `centaur robustness --episodes 1 --run RUN EXTRA`.
fn robustness(run: &Path, extra: &[&str]) -> std::process::Output {
    std::process::Command::new(env!("CARGO_BIN_EXE_centaur"))
        .args(["robustness", "--episodes", "1", "--run"])
        .arg(run)
        .args(extra)
        .output()
        .unwrap()
}

/// `centaur compare --env minitaur --algo ppo ARGS --config CONFIG --out OUT`.
fn compare_minitaur_ppo(
    args: &[&str],
    config: &std::path::Path,
    out: &std::path::Path,
) -> std::process::Output {
    centaur_with(&[&["compare", "--env", "minitaur", "--algo", "ppo"], args].concat(), config, out)
}

#[test]
fn compare_writes_the_across_seed_summary_and_every_seed_run() {
    let out = out_dir("compare");
    let config = out_dir("compare.toml");
    std::fs::write(&config, "n_steps = 64\nbatch_size = 64\nn_epochs = 2\n").unwrap();
    let args = ["--seeds", "2", "--steps", "512", "--eval-episodes", "1", "--eval-every", "256"];
    // The two seeds run at once; the resume below reruns seed 1 alone, to the same figures.
    let o = compare_minitaur_ppo(&[&args[..], &["--jobs", "2"]].concat(), &config, &out);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(stdout.contains("| hybrid (residual RL on the controller) |"), "{stdout}");
    assert!(stdout.contains("By training budget"), "{stdout}");
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("compare.json")).unwrap()).unwrap();
    assert_eq!((json["env"].as_str(), json["seeds"].as_u64()), (Some("minitaur"), Some(2)));
    for agent in ["hybrid", "pure_rl", "controller"] {
        let per_seed = json[agent]["per_seed"].as_array().unwrap();
        assert_eq!(per_seed.len(), 2, "{agent}");
        let returns: Vec<f64> = per_seed.iter().map(|s| s["return_mean"].as_f64().unwrap()).collect();
        let mean = json[agent]["return_mean"].as_f64().unwrap();
        assert!((mean - (returns[0] + returns[1]) / 2.0).abs() < 1e-9, "{agent}: {mean} vs {returns:?}");
        // Two seeds: the IQM is their mean, inside its bootstrap interval.
        let iqm = json[agent]["return_iqm"].as_f64().unwrap();
        let ci = &json[agent]["return_iqm_ci95"];
        assert!((iqm - mean).abs() < 1e-9, "{agent}: IQM {iqm} vs mean {mean}");
        assert!(ci["low"].as_f64().unwrap() <= iqm && iqm <= ci["high"].as_f64().unwrap(), "{agent}: {ci}");
    }
    // Evaluations at 256 steps and at the end; the last is the final evaluation.
    let budgets = json["budgets"].as_array().unwrap();
    assert_eq!(budgets.iter().map(|b| b["env_steps"].as_u64().unwrap()).collect::<Vec<_>>(), [256, 512]);
    for b in budgets {
        assert_eq!(b["hybrid_env_steps"], b["env_steps"], "{b}");
        assert_eq!(b["pure_env_steps"], b["env_steps"], "{b}");
    }
    assert_eq!(budgets[1]["hybrid_iqm"].as_f64(), json["hybrid"]["return_iqm"].as_f64());
    // The head-to-head read off those budgets, printed and recorded.
    assert!(
        stdout.contains("The hybrid against pure RL") && stdout.contains("at equal wall-clock"),
        "{stdout}"
    );
    let h2h = &json["head_to_head"];
    assert_eq!((h2h["budgets"].as_u64(), h2h["pure_samples"].as_u64()), (Some(2), Some(512)));
    assert_eq!(h2h["pure_final_iqm"], json["pure_rl"]["return_iqm"]);
    assert_eq!(h2h["equal_wall_clock"]["points"].as_array().map(Vec::len), Some(2));
    assert!(out.join("eval_curves.png").is_file() && out.join("eval_curves_wall.png").is_file());
    for seed in ["seed_0", "seed_1"] {
        assert!(out.join(seed).join("summary.json").is_file(), "{seed}");
        assert!(out.join(seed).join("hybrid").join("checkpoint").exists(), "{seed}");
    }
    // MCAP recordings for the first seed only.
    assert!(out.join("seed_0").join("hybrid.mcap").is_file());
    assert!(!out.join("seed_1").join("hybrid.mcap").exists());

    // Reliability probe, data loss 1: the directory is not reused silently. `--resume`
    // keeps finished seeds and reruns a seed killed before its summary, to the same figures
    // (seed 1 alone now, beside seed 0 before).
    let o = compare_minitaur_ppo(&args, &config, &out);
    assert!(!o.status.success());
    assert!(
        String::from_utf8_lossy(&o.stderr).contains("already holds a run"),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    let mut first = json.clone();
    without_wall_times(&mut first);
    let seed_0_ckpt = std::fs::read(out.join("seed_0").join("hybrid").join("checkpoint")).unwrap();
    std::fs::remove_file(out.join("seed_1").join("summary.json")).unwrap();
    let o = compare_minitaur_ppo(&[&args[..], &["--resume"]].concat(), &config, &out);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let mut resumed: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("compare.json")).unwrap()).unwrap();
    without_wall_times(&mut resumed);
    assert_eq!(resumed, first);
    assert_eq!(std::fs::read(out.join("seed_0").join("hybrid").join("checkpoint")).unwrap(), seed_0_ckpt);
    assert!(out.join("seed_1").join("summary.json").is_file());
    // Regression: `--resume` with other options than the seeds ran with (a
    // flag left out) is refused before anything trains, naming the difference; the finished
    // seeds stay as they were (it used to replace them, one after the other).
    let summaries =
        |dir: &Path| ["seed_0", "seed_1"].map(|s| std::fs::read(dir.join(s).join("summary.json")).unwrap());
    let before = summaries(&out);
    let o =
        compare_minitaur_ppo(&[&args[..], &["--resume", "--residual-scale", "0.1"]].concat(), &config, &out);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success(), "{stderr}");
    assert!(
        stderr.contains("a run of other options") && stderr.contains("residual.scale[0]: recorded"),
        "{stderr}"
    );
    assert_eq!(summaries(&out), before);
    assert_eq!(std::fs::read(out.join("seed_0").join("hybrid").join("checkpoint")).unwrap(), seed_0_ckpt);
    // A record that does not read is refused too, and left where it is.
    let record = out.join("seed_1").join("experiment.json");
    let text = std::fs::read_to_string(&record).unwrap();
    std::fs::write(&record, &text[..text.len() / 2]).unwrap();
    let o = compare_minitaur_ppo(&[&args[..], &["--resume"]].concat(), &config, &out);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && stderr.contains("cannot be read as a run's record"), "{stderr}");
    assert_eq!(summaries(&out), before);
    std::fs::write(&record, &text).unwrap();

    // An ablation of the hybrid reusing the pure-RL agents: the pure rows are the first
    // comparison's (training copied, final evaluation made again), the hybrid's its own.
    let ablation = out_dir("compare-ablation");
    let ablate = |extra: &[&str], into: &Path| {
        let mut with = vec!["--residual-scale", "0.1", "--pure-from"];
        let from = out.to_str().unwrap();
        with.push(from);
        compare_minitaur_ppo(&[&args[..], &with, extra].concat(), &config, into)
    };
    let o = ablate(&[], &ablation);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    // (Seed 1 as the resume above reran it, with its wall time.)
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("compare.json")).unwrap()).unwrap();
    let reused: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(ablation.join("compare.json")).unwrap()).unwrap();
    assert_eq!(reused["pure_rl"], json["pure_rl"]);
    assert_ne!(reused["hybrid"], json["hybrid"]);
    for (budget, before) in
        reused["budgets"].as_array().unwrap().iter().zip(json["budgets"].as_array().unwrap())
    {
        for key in ["env_steps", "pure_iqm", "pure_ci95", "pure_falls", "pure_wall_seconds"] {
            assert_eq!(budget[key], before[key], "{key}");
        }
    }
    for seed in ["seed_0", "seed_1"] {
        let metrics = |dir: &Path| std::fs::read(dir.join(seed).join("pure_rl").join("metrics.csv")).unwrap();
        assert_eq!(metrics(&ablation), metrics(&out), "{seed}");
        let record = std::fs::read_to_string(ablation.join(seed).join("experiment.json")).unwrap();
        assert!(record.contains("\"pure_from\""), "{record}");
    }
    assert!(ablation.join("seed_0").join("pure_rl.mcap").is_file());
    // The hybrid at its own hyperparameters (`--hybrid-config`), pure RL's reused: the
    // hybrid learns at its learning rate, pure RL's rows stay the first comparison's, and
    // compare.json says what the hybrid learnt with. An [env] table there is refused.
    let own = out_dir("compare-hybrid-config");
    let hybrid_toml = out_dir("compare-hybrid.toml");
    std::fs::write(&hybrid_toml, "n_steps = 64\nbatch_size = 64\nn_epochs = 2\nlearning_rate = 1e-3\n")
        .unwrap();
    let o = ablate(&["--hybrid-config", hybrid_toml.to_str().unwrap()], &own);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let with_own: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(own.join("compare.json")).unwrap()).unwrap();
    assert_eq!(with_own["pure_rl"], json["pure_rl"]);
    assert!(with_own["hybrid_learner"].as_str().unwrap().contains("learning_rate: 0.001"), "{with_own}");
    assert!(reused.get("hybrid_learner").is_none());
    let first_lr = |dir: &Path, agent: &str| -> f64 {
        let text = std::fs::read_to_string(dir.join("seed_0").join(agent).join("metrics.csv")).unwrap();
        let mut lines = text.lines();
        let column = lines.next().unwrap().split(',').position(|c| c == "learning_rate").unwrap();
        lines.next().unwrap().split(',').nth(column).unwrap().parse().unwrap()
    };
    let (hybrid_lr, pure_lr) = (first_lr(&own, "hybrid"), first_lr(&own, "pure_rl"));
    assert!((hybrid_lr / pure_lr - 1e-3 / 3e-4).abs() < 1e-9, "{hybrid_lr} {pure_lr}");
    std::fs::write(&hybrid_toml, "learning_rate = 1e-3\n[env]\nenergy_weight = 0.0\n").unwrap();
    let refused_own = out_dir("compare-hybrid-config-env");
    let o = ablate(&["--hybrid-config", hybrid_toml.to_str().unwrap()], &refused_own);
    assert!(!o.status.success());
    assert!(
        String::from_utf8_lossy(&o.stderr)
            .contains("--hybrid-config takes the hybrid's hyperparameters only")
    );
    assert!(!refused_own.exists());
    std::fs::remove_dir_all(&own).unwrap();
    std::fs::remove_file(&hybrid_toml).unwrap();
    // Refused before anything is written: pure RL trained with other options (another
    // number of envs), the output directory itself (left as it was), more seeds than the
    // source ran, a directory that holds no comparison.
    let refused = |extra: &[&str], into: &Path, expected: &str| {
        let o = ablate(extra, into);
        assert!(!o.status.success(), "{extra:?}");
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(err.contains(expected), "{extra:?}: {err}");
    };
    let other = out_dir("compare-ablation-other");
    refused(
        &["--envs", "2"],
        &other,
        "other options than this run's (only the hybrid's setup may differ): envs: recorded",
    );
    assert!(!other.join("seed_0").exists(), "a refused ablation wrote {}", other.display());
    let before = std::fs::read(out.join("compare.json")).unwrap();
    refused(&["--overwrite"], &out, "names the output directory itself");
    assert_eq!(std::fs::read(out.join("compare.json")).unwrap(), before);
    assert!(out.join("seed_1").join("pure_rl").join("checkpoint").is_file());
    let three = ["--seeds", "3", "--steps", "512", "--eval-episodes", "1", "--eval-every", "256"];
    let o = compare_minitaur_ppo(
        &[&three[..], &["--residual-scale", "0.1", "--pure-from", out.to_str().unwrap()]].concat(),
        &config,
        &other,
    );
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("seed_2 holds no run to reuse the pure-RL agent of"), "{err}");
    assert!(!other.join("seed_0").exists(), "seeds 0 and 1 trained before seed 2 was found missing");
    // A source seed without its metrics: refused up front, naming the file.
    let metrics = out.join("seed_1").join("pure_rl").join("metrics.csv");
    let aside = out.join("seed_1").join("metrics.csv.aside");
    std::fs::rename(&metrics, &aside).unwrap();
    refused(&[], &other, "pure_rl/metrics.csv is missing");
    std::fs::rename(&aside, &metrics).unwrap();
    // A source whose recorded evaluation this code does not reproduce (its summary edited
    // here, as a changed environment would show): refused when its copy is evaluated.
    let summary_path = out.join("seed_1").join("summary.json");
    let original = std::fs::read_to_string(&summary_path).unwrap();
    let mut edited: serde_json::Value = serde_json::from_str(&original).unwrap();
    edited["pure_rl"]["return_mean"] = serde_json::json!(123.5);
    std::fs::write(&summary_path, edited.to_string()).unwrap();
    refused(&[], &other, "evaluates to");
    std::fs::write(&summary_path, &original).unwrap();
    std::fs::remove_dir_all(&ablation).unwrap();
    let o = compare_minitaur_ppo(
        &[&args[..], &["--pure-from", config.to_str().unwrap()]].concat(),
        &config,
        &ablation,
    );
    assert!(String::from_utf8_lossy(&o.stderr).contains("holds no comparison"), "{o:?}");
    let _ = std::fs::remove_dir_all(&ablation);
    let _ = std::fs::remove_dir_all(&other);

    // The robustness study on seed 0's run: one episode per agent and condition.
    let seed_0 = out.join("seed_0");
    let o = robustness(&seed_0, &[]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let rows: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(seed_0.join("robustness.json")).unwrap()).unwrap();
    let labels: Vec<&str> = rows.as_array().unwrap().iter().map(|r| r["label"].as_str().unwrap()).collect();
    assert_eq!(labels.len(), 10);
    assert!(
        labels.contains(&"push 4 N·s")
            && labels.contains(&"friction 0.5")
            && labels.contains(&"base mass +20 %")
    );
    for r in rows.as_array().unwrap() {
        assert_eq!(r["controller"]["episodes"].as_u64(), Some(1));
    }
    // With the controller told only the nominal motor: its own file, robustness.json kept.
    // This run was trained with the nominal motor (the default), which the
    // study follows by default: the two files agree.
    let before = std::fs::read_to_string(seed_0.join("robustness.json")).unwrap();
    let o = robustness(&seed_0, &["--nominal-motor"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let nominal_text = std::fs::read_to_string(seed_0.join("robustness_nominal_motor.json")).unwrap();
    let nominal: serde_json::Value = serde_json::from_str(&nominal_text).unwrap();
    assert_eq!(nominal.as_array().unwrap().len(), 10);
    assert_eq!(std::fs::read_to_string(seed_0.join("robustness.json")).unwrap(), before);
    assert_eq!(nominal_text, before);
    // Behind a safety fade the run was not trained with (a filter on the trained policy,
    // accepted): its own file, robustness.json kept; a fade that ends before it starts is
    // refused, naming the field.
    let o = robustness(&seed_0, &["--fade", "0.12", "0.24"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let faded: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(seed_0.join("robustness_fade.json")).unwrap()).unwrap();
    assert_eq!(faded.as_array().unwrap().len(), 10);
    assert_eq!(std::fs::read_to_string(seed_0.join("robustness.json")).unwrap(), before);
    let o = robustness(&seed_0, &["--fade", "0.2", "0.1"]);
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("fade.end"), "{o:?}");
    // `centaur eval` behind a fade: the hybrid's own file, the fade in it; refused for pure RL
    // (not a hybrid) and for a fade that ends before it starts.
    let eval_fade = |agent: &str, env: &str, start: f64, end: f64| {
        centaur_lab::eval::run_eval(&centaur_lab::eval::EvalOptions {
            checkpoint: seed_0.join(agent),
            config: None,
            env: Some(env.into()),
            episodes: 1,
            seed: 0,
            record: None,
            out: None,
            allow_env_change: false,
            fade: Some(centaur_lab::hybrid::Fade { start, end }),
        })
    };
    let report = eval_fade("hybrid", "minitaur-residual", 0.12, 0.24).unwrap();
    let written =
        std::fs::read_to_string(seed_0.join("hybrid").join("eval_minitaur-residual_fade.json")).unwrap();
    assert_eq!(report.stats.episodes, 1);
    assert!(written.contains("\"fade\"") && written.contains("0.24"), "{written}");
    let e = eval_fade("pure_rl", "minitaur", 0.12, 0.24).unwrap_err().to_string();
    assert!(e.contains("applies to a hybrid"), "{e}");
    let e = eval_fade("hybrid", "minitaur-residual", 0.2, 0.1).unwrap_err().to_string();
    assert!(e.contains("fade.end"), "{e}");
    // A record told the drawn motor is studied with it: another table. A record of an
    // older Centaur (no identity) is refused as such, robustness.json kept.
    let record_path = seed_0.join("experiment.json");
    let record = std::fs::read_to_string(&record_path).unwrap();
    let mut edited: serde_json::Value = serde_json::from_str(&record).unwrap();
    assert_eq!(edited["controller_motor"], "nominal");
    edited["controller_motor"] = "drawn".into();
    std::fs::write(&record_path, serde_json::to_string_pretty(&edited).unwrap()).unwrap();
    let o = robustness(&seed_0, &[]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert_ne!(std::fs::read_to_string(seed_0.join("robustness.json")).unwrap(), before);
    std::fs::write(seed_0.join("robustness.json"), &before).unwrap();
    edited.as_object_mut().unwrap().remove("identity");
    std::fs::write(&record_path, serde_json::to_string_pretty(&edited).unwrap()).unwrap();
    let o = robustness(&seed_0, &[]);
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("recorded by an older Centaur"), "{o:?}");
    assert_eq!(std::fs::read_to_string(seed_0.join("robustness.json")).unwrap(), before);
    std::fs::write(&record_path, record).unwrap();
    // The flags override the setup the run records, with a warning naming both: at another
    // rating it runs; without its steering the policy no longer fits and is refused.
    let o = robustness(&seed_0, &["--rated-speed", "2.5"]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    assert!(
        err.contains("trained its hybrid with ResidualConfig {") && err.contains("rated_speed: Some(2.5)"),
        "{err}"
    );
    let o = robustness(&seed_0, &["--parts", "residual"]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && err.contains("the policy maps 41 observations to 9 actions"), "{err}");
    std::fs::write(seed_0.join("robustness.json"), &before).unwrap();
    let o = robustness(&seed_0, &["--env", "walker2d"]);
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("walker2d"));
    // A directory that holds no experiment (the comparison's own) is named as such.
    let o = robustness(&out, &[]);
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("holds no experiment.json"));
    // A hybrid checkpoint of other dimensions than its recorded setup (here pure RL's, put in
    // its place) is refused with both shapes, not evaluated.
    std::fs::copy(seed_0.join("pure_rl").join("checkpoint"), seed_0.join("hybrid").join("checkpoint"))
        .unwrap();
    let o = robustness(&seed_0, &[]);
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("the policy maps") && err.contains("this robot and residual setup need"), "{err}");
    std::fs::remove_dir_all(&out).unwrap();

    // A robot without a controller is refused with its name.
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_centaur"))
        .args(["compare", "--env", "pendulum", "--algo", "ppo", "--steps", "64", "--out"])
        .arg(&out)
        .output()
        .unwrap();
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("pendulum"));
}

/// Drops every wall-clock field, recursively.
fn without_wall_times(v: &mut serde_json::Value) {
    match v {
        serde_json::Value::Object(map) => {
            map.retain(|k, _| !k.contains("wall") && !k.contains("per_second"));
            map.values_mut().for_each(without_wall_times);
        }
        serde_json::Value::Array(items) => items.iter_mut().for_each(without_wall_times),
        _ => {}
    }
}

#[test]
fn compare_gives_the_same_figures_on_one_thread_and_on_two() {
    // With two threads the pure and the hybrid agent train side by side, each stepping its
    // environments on the worker threads, and the three agents are evaluated side by side:
    // none of it may change a figure.
    let config = out_dir("threads.toml");
    std::fs::write(&config, "n_steps = 64\nbatch_size = 64\nn_epochs = 2\n").unwrap();
    let run = |threads: &str| {
        let out = out_dir(&format!("threads-{threads}"));
        let args = ["--seeds", "1", "--steps", "256", "--eval-episodes", "2", "--threads", threads];
        let o = compare_minitaur_ppo(&args, &config, &out);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let mut json: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(out.join("compare.json")).unwrap()).unwrap();
        let mcap = std::fs::read(out.join("seed_0").join("hybrid.mcap")).unwrap();
        std::fs::remove_dir_all(&out).unwrap();
        without_wall_times(&mut json);
        (json, mcap)
    };
    let (one, one_mcap) = run("1");
    let (two, two_mcap) = run("2");
    assert_eq!(one, two);
    assert!(one_mcap == two_mcap, "the hybrid's MCAP recording differs between 1 and 2 threads");
    std::fs::remove_file(&config).unwrap();
}

#[test]
fn modular_robots_train_from_a_body_file_and_compare_refuses_them_at_once() {
    let body = concat!(env!("CARGO_MANIFEST_DIR"), "/../assets/modular/snake.json");
    let out = out_dir("modular_compare");
    let start = std::time::Instant::now();
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_centaur"))
        .args([
            "compare",
            "--env",
            &format!("modular:{body}"),
            "--algo",
            "ppo",
            "--seeds",
            "1",
            "--steps",
            "100000",
        ])
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success());
    assert!(stderr.contains("no controller"), "{stderr}");
    // Refused before any training: 100,000 steps would take over a minute.
    assert!(start.elapsed().as_secs_f64() < 20.0, "took {:?}", start.elapsed());
    let out = out_dir("modular_train");
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_centaur"))
        .args(["train", "--env", &format!("modular:{body}"), "--algo", "ppo", "--steps", "256"])
        .args(["--eval-episodes", "1"])
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let policy = centaur_lab::rl::Policy::load(&out.join("checkpoint")).unwrap();
    assert_eq!(policy.act_dim(), 4);
    let checkpoint = centaur_lab::rl::Checkpoint::read(&out.join("checkpoint")).unwrap();
    let stored: String = checkpoint.get_meta("body").unwrap();
    assert_eq!(stored, std::fs::read_to_string(body).unwrap(), "the checkpoint keeps the body");
}

/// Regression (reliability probe, silent acceptance): counts of 0 silently became 1 or gave
/// a table of zeros, and `--residual-scale 1e300` was carried as infinity; each is refused,
/// naming the option, before a directory is made.
#[test]
fn numeric_options_are_refused_not_bent() {
    let out = out_dir("refused");
    let compare = ["compare", "--env", "minitaur", "--algo", "ppo", "--steps", "64", "--out"];
    let train = ["train", "--env", "pendulum", "--algo", "ppo", "--out"];
    // Zero and negative numbers name their option (reliability probe: "-1" was taken for
    // an unexpected argument).
    for (command, args, says) in [
        (&compare[..], &["--seeds", "0"][..], "seeds = 0: must be 1 to 10000"),
        (&compare, &["--threads", "0"], "--threads"),
        (&compare, &["--envs", "0"], "envs = 0: must be 1 to 4096"),
        (&compare, &["--eval-episodes", "0"], "eval_episodes = 0: must be 1 to 100000"),
        (&compare, &["--eval-every", "1"], "eval_every = 1: must be 0 (at the end only) or at least 128"),
        (&compare, &["--residual-scale", "1e300"], "residual scale = 1e300"),
        // The controller's command is checked like `centaur control`'s: it ran silently at
        // the rating, and a NaN stopped the first step with the env's "action[0] is NaN".
        (&compare, &["--speed", "100"], "rated 3.5 m/s"),
        (&compare, &["--speed", "nan"], "command.forward_velocity = NaN"),
        (&compare, &["--explore-residual", "1e308"], "exploration.residual = 1e308"),
        (&train, &["--steps", "64", "--envs", "0"], "--envs 0"),
        (&train, &["--steps", "64", "--seed", "-1"], "'-1' for '--seed"),
        (&train, &["--steps", "-5"], "'-5' for '--steps"),
    ] {
        let o = std::process::Command::new(env!("CARGO_BIN_EXE_centaur"))
            .args(command)
            .arg(&out)
            .args(args)
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success() && stderr.contains(says), "{args:?}: {stderr}");
        assert!(!out.exists(), "{args:?} left {}", out.display());
    }
}

/// `[env]` in the run file sets the environment over its preset: it reaches every env of
/// the run (training and evaluation), the run record and the checkpoint; keys the env does
/// not have are refused, naming those it has.
#[test]
fn the_env_table_of_a_run_file_configures_the_environment() {
    let config = out_dir("env-table.toml");
    std::fs::write(
        &config,
        "n_steps = 64\nbatch_size = 64\nn_epochs = 1\nactor_hidden = [8]\ncritic_hidden = [8]\n\n[env]\nmax_episode_steps = 20\nhealthy_reward = 0.0\n",
    )
    .unwrap();
    let out = out_dir("env-table");
    let opts = TrainOptions {
        env: "walker2d".into(),
        algo: AlgoKind::Ppo,
        steps: 256,
        seed: Some(0),
        out: out.clone(),
        config: Some(config.clone()),
        threads: 1,
        n_envs: 2,
        eval_episodes: 10,
        checkpoint_every: 0,
        eval_every: 0,
        overwrite: false,
        spec: None,
    };
    train(&opts, &mut |_| {}).unwrap();
    let rows = MetricsCsv::read(&out.join("metrics.csv")).unwrap();
    assert!(rows.iter().any(|m| m.episodes > 0));
    assert!(rows.iter().filter(|m| m.episodes > 0).all(|m| m.episode_length_mean <= 20.0), "{rows:?}");
    let ckpt = centaur_rl::Checkpoint::read(&out.join("checkpoint")).unwrap();
    let settings: centaur_lab::settings::EnvSettings = ckpt.get_meta("env_settings").unwrap();
    assert_eq!((settings.max_episode_steps, settings.healthy_reward), (Some(20), Some(0.0)));
    let record = centaur_lab::train::read_run_record(&out).unwrap();
    assert_eq!(record.env_settings, settings);

    // `centaur eval`: as trained by default; a run file's [env] judges it in another
    // configuration (the seed study's no-penalty / full-penalty judgement); another env
    // whose spaces do not fit is refused.
    let eval = |config: Option<PathBuf>, env: Option<&str>, record: Option<PathBuf>| {
        centaur_lab::eval::run_eval(&centaur_lab::eval::EvalOptions {
            checkpoint: out.clone(),
            config,
            env: env.map(str::to_string),
            episodes: 3,
            seed: 7,
            record,
            out: None,
            allow_env_change: false,
            fade: None,
        })
    };
    let mcap = out.join("eval.mcap");
    let as_trained = eval(None, None, Some(mcap.clone())).unwrap();
    assert_eq!((as_trained.env.as_str(), as_trained.stats.episodes), ("walker2d", 3));
    assert!(as_trained.changed_from_training.is_empty() && as_trained.stats.length_mean <= 20.0);
    assert!(mcap.is_file() && out.join("eval.json").is_file());
    let judge = out_dir("judge.toml");
    std::fs::write(&judge, "gamma = 0.5\n[env]\nmax_episode_steps = 20\nhealthy_reward = 1.0\n").unwrap();
    let judged = eval(Some(judge.clone()), None, None).unwrap();
    assert_eq!(judged.changed_from_training, ["healthy_reward"]);
    // Same episodes, one more point per healthy step.
    let extra = judged.stats.return_mean - as_trained.stats.return_mean;
    assert!(
        (extra - as_trained.stats.length_mean).abs() < 1e-6,
        "{extra} vs {}",
        as_trained.stats.length_mean
    );
    // Each judgement keeps its own file: `eval_<config stem>.json` beside `eval.json`.
    let json = |f: &str| -> serde_json::Value {
        serde_json::from_str(&std::fs::read_to_string(out.join(f)).unwrap()).unwrap()
    };
    let stem = judge.file_stem().unwrap().to_string_lossy().into_owned();
    assert_eq!(json(&format!("eval_{stem}.json"))["settings"]["healthy_reward"].as_f64(), Some(1.0));
    assert_eq!(json("eval.json")["settings"]["healthy_reward"].as_f64(), Some(0.0), "as trained");
    assert!(eval(None, Some("ant"), None).unwrap_err().to_string().contains("policy maps"));
    std::fs::remove_file(&judge).unwrap();
    std::fs::remove_dir_all(&out).unwrap();

    for (env, text, says) in [
        ("walker2d", "[env]\nenergy_weight = 0.1\n", "energy_weight does not apply"),
        ("pendulum", "[env]\nframe_skip = 5\n", "frame_skip does not apply to the Pendulum"),
        ("pendulum", "[env]\nmax_episode_steps = 0\n", "max_episode_steps must be positive"),
        ("walker2d", "[env]\nmax_episode_step = 5\n", "max_episode_step"),
    ] {
        std::fs::write(&config, text).unwrap();
        let bad = TrainOptions { env: env.into(), ..opts.clone() };
        let e = train(&bad, &mut |_| {}).unwrap_err();
        assert!(e.to_string().contains(says), "{env} {text}: {e}");
        assert!(!out.exists());
    }
}

/// Two processes never write one run directory: while another holds it (its lock), a new
/// run, a replacement and a resume there are refused, naming it; the lock goes with the
/// process that held it (the SIGKILL test resumes at once after a kill).
#[test]
fn a_run_directory_held_by_another_process_is_refused() {
    use centaur_lab::rundir::lock_dir;
    let out = out_dir("held");
    let config = out_dir("held.toml");
    std::fs::write(&config, "n_steps = 128\nbatch_size = 64\nactor_hidden = [8]\ncritic_hidden = [8]\n")
        .unwrap();
    std::fs::create_dir_all(&out).unwrap();
    let opts = pendulum_run(AlgoKind::Ppo, 256, out.clone(), &config);
    let held = lock_dir(&out).unwrap();
    for o in [opts.clone(), TrainOptions { overwrite: true, ..opts.clone() }] {
        let e = train(&o, &mut |_| {}).unwrap_err();
        assert!(matches!(e, TrainError::Busy { .. }), "{e}");
        assert!(e.to_string().contains("another process is writing"), "{e}");
    }
    drop(held);
    train(&opts, &mut |_| {}).unwrap();
    // Another process (the CLI) is refused while this one holds the run: replacing it, or
    // resuming it once unfinished (a finished run's resume only reads its summary). The
    // lock is taken once free: a sibling test's child process may share the lock's open
    // file for the instant between its fork and its exec (seen once in a parallel run).
    let started = std::time::Instant::now();
    let held = loop {
        match lock_dir(&out) {
            Ok(held) => break held,
            Err(centaur_lab::rundir::Claim::Busy) if started.elapsed().as_secs() < 2 => {
                std::thread::sleep(std::time::Duration::from_millis(5))
            }
            Err(other) => panic!("the run's lock was not released: {other:?}"),
        }
    };
    let cli = |args: &[&str]| {
        std::process::Command::new(env!("CARGO_BIN_EXE_centaur")).args(args).arg(&out).output().unwrap()
    };
    assert!(cli(&["train", "--resume"]).status.success(), "a finished run reads back while held");
    let summary = std::fs::read(out.join("summary.json")).unwrap();
    std::fs::remove_file(out.join("summary.json")).unwrap();
    for args in [
        &["train", "--resume"][..],
        &["train", "--env", "pendulum", "--algo", "ppo", "--steps", "256", "--overwrite", "--out"],
    ] {
        let o = cli(args);
        assert!(!o.status.success(), "{args:?}");
        assert!(String::from_utf8_lossy(&o.stderr).contains("another process is writing"), "{args:?}");
    }
    assert!(out.join("run.json").is_file(), "a refused run touched the held one");
    drop(held);
    let resumed = resume(&out, 1, &mut |_| {}).unwrap();
    let finished: Summary = serde_json::from_slice(&summary).unwrap();
    assert_eq!(resumed.final_return_mean.to_bits(), finished.final_return_mean.to_bits());
    std::fs::remove_dir_all(&out).unwrap();
    std::fs::remove_file(&config).unwrap();
}

/// `centaur sweep` over a run spec: the grid's keys are the spec's table keys, each point's
/// `config.toml` is its whole spec and each run records it; the spec's seeds are run when
/// `--seeds` is not given; a grid that also gives what the spec gives, a key outside the
/// spec's tables, or two specs are refused before anything runs; `--spec` on the command
/// line is the same as the file's `spec`.
#[test]
fn a_sweep_over_a_spec_varies_its_table_keys() {
    let dir = out_dir("sweep-spec");
    std::fs::create_dir_all(&dir).unwrap();
    let spec = dir.join("spec.toml");
    std::fs::write(
        &spec,
        "schema = 1\nrobot = \"pendulum\"\nalgo = \"ppo\"\nseeds = 1\nsteps = 1024\nenvs = 2\neval_every = 512\n\n[learner]\nbase = \"defaults\"\nn_steps = 128\nbatch_size = 128\nn_epochs = 1\nactor_hidden = [8]\ncritic_hidden = [8]\n",
    )
    .unwrap();
    let grid = dir.join("grid.toml");
    let grid_text = "checkpoint_every = 512\n[grid]\n\"learner.learning_rate\" = [3e-4, 1e-3]\n";
    std::fs::write(&grid, format!("spec = \"spec.toml\"\n{grid_text}")).unwrap();
    let out = dir.join("out");
    let sweep = |args: &[&str]| {
        std::process::Command::new(env!("CARGO_BIN_EXE_centaur")).arg("sweep").args(args).output().unwrap()
    };
    let (g, o) = (grid.to_str().unwrap(), out.to_str().unwrap());
    let run = sweep(&["--jobs", "2", "--grid", g, "--out", o]);
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("sweep.json")).unwrap()).unwrap();
    let points = json["points"].as_array().unwrap();
    assert_eq!(points.len(), 2);
    assert_eq!(points[1]["values"]["learner.learning_rate"].as_str(), Some("0.001"));
    for p in points {
        assert_eq!(p["final_returns"].as_array().unwrap().len(), 1, "the spec's one seed");
    }
    // The generated results page: the grid with the spec resolved, the table, every seed.
    let page = std::fs::read_to_string(out.join("results.md")).unwrap();
    for part in ["Generated by `centaur sweep`", "over the spec, resolved", "| p001 |", "Host: "] {
        assert!(page.contains(part), "{part}: {page}");
    }
    let record: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("p001/seed_0/run.json")).unwrap()).unwrap();
    assert_eq!(record["spec"]["learner"]["learning_rate"], 0.001);
    assert_eq!(record["spec"]["learner"]["n_steps"], 128);
    let point_spec = out.join("p001").join("config.toml");
    let o2 = std::process::Command::new(env!("CARGO_BIN_EXE_centaur"))
        .args(["spec", "--train"])
        .arg(&point_spec)
        .output()
        .unwrap();
    let printed = String::from_utf8_lossy(&o2.stdout);
    assert!(o2.status.success() && printed.contains("0.001"), "{o2:?}");
    // The same grid with the spec on the command line, and an override: checked, listed.
    let bare = dir.join("bare.toml");
    std::fs::write(&bare, grid_text).unwrap();
    let (b, sp) = (bare.to_str().unwrap(), spec.to_str().unwrap());
    let check = sweep(&["--spec", sp, "--set", "seeds=4", "--grid", b, "--check"]);
    let listed = String::from_utf8_lossy(&check.stdout);
    assert!(check.status.success() && listed.contains("2 points × 4 seeds"), "{check:?}");
    // Refused before anything runs, each naming why.
    let refused = |text: &str, extra: &[&str], why: &str| {
        std::fs::write(&bare, text).unwrap();
        let o = sweep(&[extra, &["--grid", b, "--check"]].concat());
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success() && err.contains(why), "{text}: {err}");
    };
    refused(&format!("spec = \"spec.toml\"\nsteps = 64\n{grid_text}"), &[], "`steps` is given by the spec");
    refused(
        "spec = \"spec.toml\"\n[grid]\nlearning_rate = [1e-3]\n",
        &[],
        "the grid's keys are its table keys",
    );
    refused(&format!("spec = \"spec.toml\"\n{grid_text}"), &["--spec", sp], "give one");
    refused("spec = \"spec.toml\"\n[grid]\n\"learner.learning_rat\" = [1e-3]\n", &[], "learning_rat");
    refused("[grid]\nlearning_rate = [1e-3]\n", &[], "missing field `env`");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// `centaur sweep`: a 2 × 1 grid × 2 seeds on two jobs; one run directory per point and
/// seed, the per-point IQM in sweep.json; a rerun keeps finished runs and resumes a killed
/// one to the same figures; another grid in the same directory is refused.
#[test]
fn a_sweep_runs_its_grid_in_parallel_and_resumes() {
    let out = out_dir("sweep");
    let grid = out_dir("sweep-grid.toml");
    std::fs::write(
        &grid,
        "env = \"pendulum\"\nalgo = \"ppo\"\nsteps = 1024\nenvs = 2\ncheckpoint_every = 512\n\n[base]\nn_steps = 128\nbatch_size = 128\nn_epochs = 1\nactor_hidden = [8]\ncritic_hidden = [8]\n\n[grid]\nlearning_rate = [3e-4, 1e-3]\n",
    )
    .unwrap();
    let sweep = |extra: &[&str]| {
        std::process::Command::new(env!("CARGO_BIN_EXE_centaur"))
            .args(["sweep", "--seeds", "2", "--jobs", "2", "--grid"])
            .arg(&grid)
            .arg("--out")
            .arg(&out)
            .args(extra)
            .output()
            .unwrap()
    };
    let o = sweep(&[]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert_eq!(stdout.lines().filter(|l| l.starts_with('[')).count(), 4, "{stdout}");
    let json = || -> serde_json::Value {
        serde_json::from_str(&std::fs::read_to_string(out.join("sweep.json")).unwrap()).unwrap()
    };
    let first = json();
    let points = first["points"].as_array().unwrap();
    assert_eq!(points.len(), 2);
    assert_eq!(points[1]["values"]["learning_rate"].as_str(), Some("0.001"));
    for p in points {
        assert_eq!(p["final_returns"].as_array().unwrap().len(), 2);
        assert!(p["return_iqm"].as_f64().unwrap().is_finite());
    }
    assert!(out.join("p001").join("seed_1").join("checkpoint").exists());
    assert!(out.join("sweep_curves.png").is_file());
    // p001 seed 1 "killed" after its first checkpoint: its summary gone, metrics rows past
    // the checkpoint left over. The rerun resumes it alone to the same figures.
    let killed = out.join("p001").join("seed_1");
    std::fs::remove_file(killed.join("summary.json")).unwrap();
    let kept = std::fs::read(out.join("p000").join("seed_0").join("checkpoint")).unwrap();
    let o = sweep(&[]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(stdout.contains("[1] p001 seed 1") && !stdout.contains("[2]"), "{stdout}");
    assert_eq!(json()["points"], first["points"]);
    assert_eq!(std::fs::read(out.join("p000").join("seed_0").join("checkpoint")).unwrap(), kept);
    // Another grid: refused, then replaced with --overwrite.
    std::fs::write(&grid, std::fs::read_to_string(&grid).unwrap().replace("1e-3", "3e-3")).unwrap();
    let o = sweep(&[]);
    assert!(!o.status.success() && String::from_utf8_lossy(&o.stderr).contains("another grid"));
    // A typo in a key is named before anything runs.
    std::fs::write(&grid, "env = \"pendulum\"\nalgo = \"ppo\"\nsteps = 64\n[grid]\nlearning_rat = [1e-3]\n")
        .unwrap();
    let o = sweep(&["--overwrite"]);
    assert!(!o.status.success() && String::from_utf8_lossy(&o.stderr).contains("learning_rat"));
    std::fs::remove_dir_all(&out).unwrap();
    std::fs::remove_file(&grid).unwrap();
}

/// A sweep's judges (the seed study's no-penalty / full-penalty judgement): every final
/// policy is also evaluated on its env with each judge's `[env]` table; a judge with the
/// training settings reproduces the final evaluation, a costlier one scores lower; judging
/// is resumable, and a judge key the robot lacks is refused before anything runs.
#[test]
fn a_sweep_judges_every_final_policy() {
    let out = out_dir("sweep-judges");
    let grid = out_dir("sweep-judges.toml");
    let text = "env = \"gecko\"\nalgo = \"ppo\"\nsteps = 256\ncheckpoint_every = 128\neval_every = 128\n\n[base]\nn_steps = 64\nbatch_size = 64\nn_epochs = 1\nactor_hidden = [8]\ncritic_hidden = [8]\n[base.env]\nmax_episode_steps = 20\n\n[grid]\nlearning_rate = [3e-4]\n\n[judges.as_trained]\nmax_episode_steps = 20\n\n[judges.costly]\nmax_episode_steps = 20\nctrl_cost_weight = 10.0\n";
    std::fs::write(&grid, text).unwrap();
    let sweep = || {
        std::process::Command::new(env!("CARGO_BIN_EXE_centaur"))
            .args(["sweep", "--seeds", "2", "--jobs", "2", "--grid"])
            .arg(&grid)
            .arg("--out")
            .arg(&out)
            .output()
            .unwrap()
    };
    let o = sweep();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(stdout.contains("judge costly"), "the table shows the judges: {stdout}");
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("sweep.json")).unwrap()).unwrap();
    let p = &json["points"][0];
    let finals: Vec<f64> =
        p["final_returns"].as_array().unwrap().iter().map(|v| v.as_f64().unwrap()).collect();
    let judged = |name: &str| -> Vec<f64> {
        p["judged"][name]["returns"].as_array().unwrap().iter().map(|v| v.as_f64().unwrap()).collect()
    };
    assert_eq!(judged("as_trained"), finals, "the training settings judge as the final evaluation");
    for (costly, plain) in judged("costly").iter().zip(&finals) {
        assert!(costly < plain, "{costly} vs {plain}");
    }
    assert_eq!(p["judged"]["costly"]["episodes"].as_u64(), Some(20));
    // Each run evaluated its checkpoint every 128 steps, the final one last.
    let evals = centaur_lab::train::read_evaluations(&out.join("p000/seed_1/evaluations.csv")).unwrap();
    assert_eq!(evals.iter().map(|e| e.step).collect::<Vec<_>>(), [128, 256]);
    // A judgement lost (killed while judging) is redone alone, to the same figure.
    let lost = out.join("p000/seed_0/judge_costly.json");
    let before = std::fs::read_to_string(&lost).unwrap();
    std::fs::remove_file(&lost).unwrap();
    let o = sweep();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert_eq!(std::fs::read_to_string(&lost).unwrap(), before);
    // A key the gecko does not have, in a judge: named before anything runs.
    std::fs::write(&grid, text.replace("ctrl_cost_weight = 10.0", "drift_weight = 1.0")).unwrap();
    std::fs::remove_dir_all(&out).unwrap();
    let o = sweep();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && err.contains("judge `costly`") && err.contains("drift_weight"), "{err}");
    assert!(!out.join("p000").exists(), "a refused sweep ran");
    std::fs::remove_file(&grid).unwrap();
}

/// Every study in `studies/` is a grid `centaur sweep` accepts: its points' and judges'
/// settings fit their robots (checked without running, as `centaur sweep --check` does).
#[test]
fn every_study_grid_checks() {
    let dir = std::path::Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/..")).join("studies");
    let mut files: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    files.sort();
    assert!(files.len() >= 15, "{files:?}");
    for f in &files {
        let g = centaur_lab::sweep::check_grid(f).unwrap_or_else(|e| panic!("{}: {e}", f.display()));
        assert!(!g.points.is_empty());
        let name = f.file_name().unwrap().to_string_lossy();
        if name.starts_with("c_") {
            assert_eq!(g.grid.judges.keys().collect::<Vec<_>>(), ["full_penalty", "no_penalty"], "{name}");
        }
    }
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_centaur"))
        .args(["sweep", "--check", "--grid"])
        .arg(dir.join("b_ppo_gecko_observations.toml"))
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(stdout.contains("4 points") && stdout.contains("env.observation = \"hinges\""), "{stdout}");
    // Each study is one command: all its files in one `--grid` (as `studies/d_*.toml` expands).
    for study in ["a_", "b_", "c_", "d_", "e_"] {
        let of_study: Vec<_> =
            files.iter().filter(|f| f.file_name().unwrap().to_string_lossy().starts_with(study)).collect();
        assert!(!of_study.is_empty(), "{study}");
        let o = std::process::Command::new(env!("CARGO_BIN_EXE_centaur"))
            .args(["sweep", "--check", "--grid"])
            .args(&of_study)
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let stdout = String::from_utf8_lossy(&o.stdout);
        for f in &of_study {
            assert!(stdout.contains(&f.display().to_string()), "{study}: {stdout}");
        }
    }
}

/// A study of several grid files runs with one command, each grid into `OUT/<file stem>`;
/// every file is checked before the first runs, and two files of one name are refused.
#[test]
fn a_study_of_several_grids_runs_with_one_command() {
    let out = out_dir("study");
    let dir = out_dir("study-grids");
    std::fs::create_dir_all(dir.join("other")).unwrap();
    let grid = |lr: &str| {
        format!(
            "env = \"pendulum\"\nalgo = \"ppo\"\nsteps = 256\n\n[base]\nn_steps = 128\nbatch_size = 128\nn_epochs = 1\nactor_hidden = [8]\ncritic_hidden = [8]\nlearning_rate = {lr}\n"
        )
    };
    let (one, two) = (dir.join("s_one.toml"), dir.join("s_two.toml"));
    std::fs::write(&one, grid("3e-4")).unwrap();
    std::fs::write(&two, grid("1e-3")).unwrap();
    std::fs::write(dir.join("other").join("s_one.toml"), grid("1e-3")).unwrap();
    std::fs::write(dir.join("s_bad.toml"), grid("-1.0")).unwrap();
    let sweep = |grids: &[PathBuf]| {
        std::process::Command::new(env!("CARGO_BIN_EXE_centaur"))
            .args(["sweep", "--seeds", "1", "--jobs", "1", "--out"])
            .arg(&out)
            .arg("--grid")
            .args(grids)
            .output()
            .unwrap()
    };
    // A bad file or two of one name: refused before anything runs.
    let o = sweep(&[one.clone(), dir.join("s_bad.toml")]);
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("s_bad.toml"));
    let o = sweep(&[one.clone(), dir.join("other").join("s_one.toml")]);
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("same name"));
    assert!(!out.exists(), "a refused study ran");
    let o = sweep(&[one.clone(), two.clone()]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    for stem in ["s_one", "s_two"] {
        let json: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(out.join(stem).join("sweep.json")).unwrap())
                .unwrap();
        assert_eq!(json["points"].as_array().unwrap().len(), 1);
    }
    // The second file changed since: its directory holds another grid's sweep, refused
    // before the first grid is looked at again.
    std::fs::write(&two, grid("2e-3")).unwrap();
    let o = sweep(&[one, two]);
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("s_two holds a sweep of another grid"));
    assert!(!String::from_utf8_lossy(&o.stdout).contains("=="), "a grid ran");
    std::fs::remove_dir_all(&out).unwrap();
    std::fs::remove_dir_all(&dir).unwrap();
}

/// The run files shipped in `configs/` (named `<robot>_<algo>_….toml`) parse for their
/// algorithm, with no `[env]` table in the hybrid's own (`--hybrid-config` refuses one), and
/// the hybrid's twice-the-updates settings (and the faster critic's rate, the critic's
/// burn-in) are what the README says.
#[test]
fn the_shipped_run_files_parse() {
    let dir = Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/..")).join("configs");
    let mut seen = 0;
    for entry in std::fs::read_dir(&dir).unwrap() {
        let path = entry.unwrap().path();
        let text = std::fs::read_to_string(&path).unwrap();
        if text.lines().any(|l| l.starts_with("schema")) {
            // A run spec, not a run file: `centaur_lab::spec`'s tests resolve every one.
            continue;
        }
        let name = path.file_stem().unwrap().to_str().unwrap().to_string();
        let algo = name.split('_').nth(1).unwrap();
        let kind = match algo {
            "ppo" => AlgoKind::Ppo,
            other => panic!("{name}: a run file for {other}, not checked here"),
        };
        let (config, settings) = centaur_lab::train::parse_run_config(kind, &text, &path).unwrap();
        if name.contains("hybrid") {
            assert!(settings.is_empty(), "{name}: an [env] table");
            let centaur_rl::AlgoConfig::Ppo(p) = config else { panic!("{name}") };
            assert_eq!((p.n_steps, p.batch_size, p.n_epochs, p.learning_rate), (512, 128, 10, 5e-4));
            assert_eq!(p.anneal_lr, !name.ends_with("constant_lr"), "{name}");
            let burn_in = name.ends_with("burn_in");
            let critic_lr = if name.ends_with("critic_lr") || burn_in { Some(1e-3) } else { None };
            assert_eq!(p.critic_learning_rate, critic_lr, "{name}");
            assert_eq!(p.actor_burn_in_steps, if burn_in { 20_480 } else { 0 }, "{name}");
        } else {
            // The pure agents' files: the fast settings, the body state observed where named.
            let centaur_rl::AlgoConfig::Ppo(p) = config else { panic!("{name}") };
            assert_eq!((p.n_steps, p.batch_size, p.n_epochs, p.learning_rate), (1024, 256, 10, 5e-4));
            let observed = name.ends_with("body_state");
            assert_eq!(settings.observe_body_state, observed.then_some(true), "{name}");
            assert_eq!(settings.given().len(), usize::from(observed), "{name}");
        }
        seen += 1;
    }
    assert!(seen >= 2, "{seen} run files in {}", dir.display());
}

/// A hybrid trained from a run spec (a setup that is not the robot's preset: a wider residual
/// and two steered parts) records its resolved spec, resumes from `run.json` alone to the
/// uninterrupted result bit for bit, and is evaluated from its checkpoint alone with the
/// setup it trained with.
#[test]
fn a_spec_trained_hybrid_resumes_and_evaluates_from_its_record_alone() {
    let dir = out_dir("spec-runs");
    std::fs::create_dir_all(&dir).unwrap();
    let spec_path = dir.join("hybrid.toml");
    std::fs::write(
        &spec_path,
        "schema = 1\nrobot = \"minitaur-residual\"\nalgo = \"ppo\"\nsteps = 4096\nenvs = 1\neval_every = 0\n\
         [learner]\nn_steps = 128\nbatch_size = 64\nn_epochs = 2\n\
         [hybrid]\nresidual_scale = 0.5\nsteering = { speed = 2.5, cadence = 0.75 }\n\
         [controller]\nspeed = 3.0\nrated_speed = 4.5\n",
    )
    .unwrap();
    let resolved = centaur_lab::spec::RunSpec::read(&spec_path, &[])
        .unwrap()
        .resolve(centaur_lab::spec::Purpose::Train)
        .unwrap();
    assert_eq!(resolved.hybrid.as_ref().map(|h| h.steering.dim()), Some(2));
    let whole = dir.join("whole");
    let opts = TrainOptions {
        env: resolved.robot.clone(),
        algo: AlgoKind::Ppo,
        steps: resolved.steps,
        seed: None,
        out: whole.clone(),
        config: None,
        threads: 1,
        n_envs: resolved.envs,
        eval_episodes: 10,
        checkpoint_every: 1024,
        eval_every: 0,
        overwrite: false,
        spec: Some(resolved.clone()),
    };
    train(&opts, &mut |_| {}).unwrap();
    let recorded: centaur_lab::spec::SpecRecord =
        serde_json::from_str(&std::fs::read_to_string(whole.join("spec.json")).unwrap()).unwrap();
    assert_eq!(recorded.spec, resolved);

    // The same spec from the command line, killed after its second checkpoint, resumed.
    let killed = dir.join("killed");
    let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_centaur"))
        .args(["train", "--checkpoint-every", "1024", "--eval-episodes", "10", "--spec"])
        .arg(&spec_path)
        .arg("--out")
        .arg(&killed)
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let ckpt = killed.join("checkpoint");
    let started = std::time::Instant::now();
    loop {
        let steps =
            centaur_rl::Checkpoint::read(&ckpt).ok().and_then(|c| c.get_meta::<u64>("steps_done").ok());
        if steps.is_some_and(|s| s >= 2048) {
            break;
        }
        assert!(child.try_wait().unwrap().is_none(), "the run ended before it could be killed");
        assert!(started.elapsed().as_secs() < 120, "no second checkpoint after 120 s");
        std::thread::sleep(std::time::Duration::from_millis(1));
    }
    child.kill().unwrap();
    child.wait().unwrap();
    assert!(!killed.join("summary.json").exists(), "the run finished before the kill");
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_centaur"))
        .args(["train", "--resume"])
        .arg(&killed)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert_eq!(metric_bits(&killed), metric_bits(&whole));
    assert_eq!(summary_bits(&killed), summary_bits(&whole));

    // `centaur eval` with the checkpoint alone rebuilds the spec's hybrid (10 actions: 8
    // joints and 2 steered parts, where the preset's has 9).
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_centaur"))
        .args(["eval", "--episodes", "1", "--checkpoint"])
        .arg(whole.join("checkpoint"))
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(String::from_utf8_lossy(&o.stdout).contains("minitaur-residual"));
    // The library builds that environment from the checkpoint alone (the Python package's
    // `CentaurEnv.from_checkpoint`).
    let file = whole.join("checkpoint");
    let checkpoint = centaur_rl::Checkpoint::read(&file).unwrap();
    let env = centaur_lab::eval::trained_source(&checkpoint, &file).unwrap().make().unwrap();
    assert_eq!((env.name(), env.action_space().dim()), ("minitaur-residual", 10));
    std::fs::remove_dir_all(&dir).unwrap();
}
