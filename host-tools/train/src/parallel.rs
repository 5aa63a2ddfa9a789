//! Independent jobs (the folds of a benchmark) on every core, their results in job order.
//!
//! Each fold derives its training randomness from its own seed and index and shares nothing
//! mutable with the others, so running folds side by side gives the same bits as one after the
//! other; only the wall clock changes.
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::Mutex;

/// Threads for `jobs` jobs: the cores this process may use, at most one per job.
pub fn threads_for(jobs: usize) -> usize {
    std::thread::available_parallelism()
        .map_or(1, |n| n.get())
        .min(jobs)
        .max(1)
}

/// `job(0)`, ..., `job(n - 1)` on up to `threads` threads; the results in job order. On an error
/// no new job starts, and the error of the lowest-numbered failed job is returned.
pub fn map_in_order<T, E, F>(n: usize, threads: usize, job: F) -> Result<Vec<T>, E>
where
    T: Send,
    E: Send,
    F: Fn(usize) -> Result<T, E> + Sync,
{
    if threads <= 1 || n <= 1 {
        return (0..n).map(job).collect();
    }
    let next = AtomicUsize::new(0);
    let failed = AtomicBool::new(false);
    let results: Mutex<Vec<Option<Result<T, E>>>> = Mutex::new((0..n).map(|_| None).collect());
    std::thread::scope(|scope| {
        for _ in 0..threads.min(n) {
            scope.spawn(|| loop {
                if failed.load(Ordering::Relaxed) {
                    break;
                }
                let i = next.fetch_add(1, Ordering::Relaxed);
                if i >= n {
                    break;
                }
                let result = job(i);
                if result.is_err() {
                    failed.store(true, Ordering::Relaxed);
                }
                let mut slots = results.lock().unwrap_or_else(|e| e.into_inner());
                slots[i] = Some(result);
            });
        }
    });
    let slots = results.into_inner().unwrap_or_else(|e| e.into_inner());
    let mut out = Vec::with_capacity(n);
    for slot in slots {
        match slot {
            Some(Ok(value)) => out.push(value),
            Some(Err(e)) => return Err(e),
            // Not started: a lower-numbered job failed first, and its error came back above.
            None => break,
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn results_come_back_in_job_order_whatever_the_threads() {
        for threads in [1, 2, 4] {
            let out: Result<Vec<usize>, ()> = map_in_order(9, threads, |i| {
                std::thread::sleep(std::time::Duration::from_millis((9 - i) as u64));
                Ok(i * i)
            });
            assert_eq!(out.unwrap(), (0..9).map(|i| i * i).collect::<Vec<_>>());
        }
    }

    #[test]
    fn the_lowest_numbered_error_is_returned() {
        for threads in [1, 2, 3] {
            let out: Result<Vec<usize>, usize> =
                map_in_order(6, threads, |i| if i >= 2 { Err(i) } else { Ok(i) });
            assert_eq!(out.unwrap_err(), 2, "{threads} threads");
        }
    }
}
