//! The work queue `centaur sweep` and `centaur compare` share: independent runs taken in
//! order by a fixed number of threads, each result kept at its run's index so that what the
//! caller builds from them does not depend on the number of threads.

use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

/// Runs `task(i)` for every `i` in `0..n` on up to `jobs` threads (on the calling thread
/// when there is one job), each thread taking the next index in order. After a task fails
/// no new one starts; those already running finish. Returns every index's result in index
/// order, `None` for the indices never started.
pub(crate) fn run_indexed<T: Send, E: Send>(
    n: usize,
    jobs: usize,
    task: impl Fn(usize) -> Result<T, E> + Sync,
) -> Vec<Option<Result<T, E>>> {
    let next = AtomicUsize::new(0);
    let stop = AtomicBool::new(false);
    let slots: Vec<Mutex<Option<Result<T, E>>>> = (0..n).map(|_| Mutex::new(None)).collect();
    let worker = || {
        while !stop.load(Ordering::Relaxed) {
            let i = next.fetch_add(1, Ordering::Relaxed);
            if i >= n {
                break;
            }
            let result = task(i);
            if result.is_err() {
                stop.store(true, Ordering::Relaxed);
            }
            *slots[i].lock().unwrap_or_else(|e| e.into_inner()) = Some(result);
        }
    };
    let jobs = jobs.clamp(1, n.max(1));
    if jobs == 1 {
        worker();
    } else {
        std::thread::scope(|s| {
            for _ in 0..jobs {
                s.spawn(worker);
            }
        });
    }
    slots.into_iter().map(|m| m.into_inner().unwrap_or_else(|e| e.into_inner())).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn results_keep_their_index_and_a_failure_stops_new_tasks() {
        for jobs in [1, 3, 50] {
            let squares = run_indexed(10, jobs, |i| Ok::<usize, ()>(i * i));
            let expected: Vec<_> = (0..10).map(|i| Some(Ok(i * i))).collect();
            assert_eq!(squares, expected, "{jobs} jobs");
        }
        // One job: the failure at 2 stops the queue there.
        let r = run_indexed(5, 1, |i| if i == 2 { Err(i) } else { Ok(i) });
        assert_eq!(r, [Some(Ok(0)), Some(Ok(1)), Some(Err(2)), None, None]);
        assert!(run_indexed(0, 4, Ok::<usize, ()>).is_empty());
    }
}
