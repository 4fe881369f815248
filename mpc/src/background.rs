//! The convex MPC on a worker thread ([`crate::MpcExecution::Background`]), the arrangement of the
//! MIT Cheetah controller: the control loop hands the MPC its inputs and returns at once,
//! and adopts each plan when it is ready.
//!
//! One worker thread per controller owns the [`ConvexMpc`]. The two sides share a slot
//! behind a mutex: the staged inputs of the next solve (a newer submission replaces one the
//! worker has not taken yet) and the last finished plan. Every buffer is allocated when the
//! controller is built; a submission or a poll copies into same-sized buffers and holds the
//! lock only for that copy, never during a solve. A controller reset (an episode
//! reset) bumps a generation number so that a plan solved for the old episode is dropped.

use std::sync::{Arc, Condvar, Mutex, MutexGuard, PoisonError};
use std::thread::JoinHandle;
use std::time::Instant;

use nalgebra::Vector3;

use crate::convex_mpc::{ConvexMpc, MpcInput};
use crate::error::ConfigError;
use crate::qp::QpStatus;

/// One solved (or failed) MPC problem, as the controller uses it.
#[derive(Clone, Debug)]
pub(crate) struct MpcPlan {
    /// Time of the state the plan starts from (s).
    pub t: f64,
    pub status: QpStatus,
    pub iterations: u32,
    pub solve_us: f64,
    /// Forces, `k · nc + contact`.
    pub forces: Vec<Vector3<f64>>,
    /// Predicted CoM per step.
    pub com: Vec<[f64; 3]>,
}

impl MpcPlan {
    pub(crate) fn new(horizon: usize, nc: usize) -> Self {
        MpcPlan {
            t: 0.0,
            status: QpStatus::NotRun,
            iterations: 0,
            solve_us: 0.0,
            forces: vec![Vector3::zeros(); horizon * nc],
            com: vec![[0.0; 3]; horizon],
        }
    }

    /// Solves `mpc` (inputs already in `mpc.input`) for the state measured at `t`.
    pub(crate) fn solve(&mut self, mpc: &mut ConvexMpc, t: f64, horizon: usize, nc: usize) {
        let t0 = Instant::now();
        self.status = mpc.solve();
        self.solve_us = t0.elapsed().as_secs_f64() * 1e6;
        self.iterations = mpc.iterations();
        self.t = t;
        if self.status.is_ok() {
            for k in 0..horizon {
                for ci in 0..nc {
                    self.forces[k * nc + ci] = mpc.force(k, ci);
                }
                let x = mpc.predicted_state(k);
                self.com[k] = [x[3], x[4], x[5]];
            }
        }
    }

    /// Copies `other` without allocating (same horizon and contact count).
    fn copy_from(&mut self, other: &MpcPlan) {
        self.t = other.t;
        self.status = other.status;
        self.iterations = other.iterations;
        self.solve_us = other.solve_us;
        self.forces.copy_from_slice(&other.forces);
        self.com.copy_from_slice(&other.com);
    }
}

/// Copies MPC inputs between same-sized buffers without allocating.
fn copy_input(dst: &mut MpcInput, src: &MpcInput) {
    dst.x0 = src.x0;
    dst.state_weights = src.state_weights;
    dst.x_ref.copy_from_slice(&src.x_ref);
    for (d, s) in dst.contact.iter_mut().zip(&src.contact) {
        d.copy_from_slice(s);
    }
    for (d, s) in dst.foot.iter_mut().zip(&src.foot) {
        d.copy_from_slice(s);
    }
}

struct Slot {
    /// Inputs of the next solve, valid while `job_pending`.
    job: MpcInput,
    job_t: f64,
    job_generation: u64,
    job_pending: bool,
    /// The worker has taken a job and not yet published its plan.
    busy: bool,
    /// The last finished plan, valid while `result_ready`.
    result: MpcPlan,
    result_generation: u64,
    result_ready: bool,
    shutdown: bool,
    /// The worker has exited (only after `shutdown`, or if a solve panicked).
    worker_gone: bool,
}

struct Shared {
    slot: Mutex<Slot>,
    /// Signals both ways: a job or shutdown for the worker, a result for the controller.
    changed: Condvar,
}

impl Shared {
    fn lock(&self) -> MutexGuard<'_, Slot> {
        // A panic while the lock was held leaves plain data behind: keep using it.
        self.slot.lock().unwrap_or_else(PoisonError::into_inner)
    }
}

/// Marks the worker gone when its thread ends, however it ends.
struct GoneOnExit(Arc<Shared>);

impl Drop for GoneOnExit {
    fn drop(&mut self) {
        self.0.lock().worker_gone = true;
        self.0.changed.notify_all();
    }
}

/// What [`BackgroundMpc::poll`] found.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Poll {
    /// A plan of the current generation, now in `latest`.
    Plan,
    /// No plan (yet).
    Nothing,
    /// The worker has ended: no plan will ever come.
    Gone,
}

/// The controller's handle on the worker.
pub(crate) struct BackgroundMpc {
    /// Inputs being assembled for the next submission.
    pub staging: MpcInput,
    /// The plan last taken from the worker.
    pub latest: MpcPlan,
    generation: u64,
    shared: Arc<Shared>,
    worker: Option<JoinHandle<()>>,
}

impl BackgroundMpc {
    /// Moves `mpc` to a new worker thread.
    pub(crate) fn start(mut mpc: ConvexMpc, horizon: usize, nc: usize) -> Result<Self, ConfigError> {
        let shared = Arc::new(Shared {
            slot: Mutex::new(Slot {
                job: mpc.input.clone(),
                job_t: 0.0,
                job_generation: 0,
                job_pending: false,
                busy: false,
                result: MpcPlan::new(horizon, nc),
                result_generation: 0,
                result_ready: false,
                shutdown: false,
                worker_gone: false,
            }),
            changed: Condvar::new(),
        });
        let staging = mpc.input.clone();
        let theirs = Arc::clone(&shared);
        let worker = std::thread::Builder::new()
            .name("centaur-mpc".into())
            .spawn(move || {
                let _gone = GoneOnExit(Arc::clone(&theirs));
                let mut plan = MpcPlan::new(horizon, nc);
                loop {
                    let (t, generation) = {
                        let mut s = theirs.lock();
                        while !s.job_pending && !s.shutdown {
                            s = theirs.changed.wait(s).unwrap_or_else(PoisonError::into_inner);
                        }
                        if s.shutdown {
                            return;
                        }
                        copy_input(&mut mpc.input, &s.job);
                        s.job_pending = false;
                        s.busy = true;
                        (s.job_t, s.job_generation)
                    };
                    plan.solve(&mut mpc, t, horizon, nc);
                    let mut s = theirs.lock();
                    s.result.copy_from(&plan);
                    s.result_generation = generation;
                    s.result_ready = true;
                    s.busy = false;
                    drop(s);
                    theirs.changed.notify_all();
                }
            })
            .map_err(ConfigError::Thread)?;
        Ok(BackgroundMpc {
            staging,
            latest: MpcPlan::new(horizon, nc),
            generation: 0,
            shared,
            worker: Some(worker),
        })
    }

    /// Hands the staged inputs, for the state measured at `t`, to the worker (replacing a
    /// submission it has not started).
    pub(crate) fn submit(&mut self, t: f64) {
        let mut s = self.shared.lock();
        copy_input(&mut s.job, &self.staging);
        s.job_t = t;
        s.job_generation = self.generation;
        s.job_pending = true;
        drop(s);
        self.shared.changed.notify_all();
    }

    /// Takes a finished plan of this generation into `self.latest`; with `wait`, blocks
    /// until one exists or nothing more can come.
    pub(crate) fn poll(&mut self, wait: bool) -> Poll {
        let mut s = self.shared.lock();
        loop {
            if s.result_ready && s.result_generation == self.generation {
                self.latest.copy_from(&s.result);
                s.result_ready = false;
                return Poll::Plan;
            }
            if s.result_ready {
                s.result_ready = false; // solved for an episode that has been reset
            }
            if s.worker_gone {
                return Poll::Gone;
            }
            // Nothing will come now: not waiting, or no work queued or under way.
            if !wait || !s.job_pending && !s.busy {
                return Poll::Nothing;
            }
            s = self.shared.changed.wait(s).unwrap_or_else(PoisonError::into_inner);
        }
    }

    /// Whether the worker has ended (a solve panicked).
    pub(crate) fn gone(&self) -> bool {
        self.shared.lock().worker_gone
    }

    /// Drops pending work and any plan not yet taken (an episode reset).
    pub(crate) fn reset(&mut self) {
        self.generation += 1;
        let mut s = self.shared.lock();
        s.job_pending = false;
        s.result_ready = false;
    }
}

impl Drop for BackgroundMpc {
    fn drop(&mut self) {
        self.shared.lock().shutdown = true;
        self.shared.changed.notify_all();
        if let Some(w) = self.worker.take() {
            let _ = w.join();
        }
    }
}
