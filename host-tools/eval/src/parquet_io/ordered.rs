//! An ordered parallel map: the calling thread makes jobs one after another (decodes Parquet
//! batches, cuts CSV into chunks), `threads` workers turn each job into a result (parse, score,
//! encode), and the calling thread takes the results in the order the jobs were made (writes).
//!
//! At most `max_in_flight` jobs are made but not yet taken back, so memory is bounded by that
//! many jobs and results whatever the input size. Each job has its own one-slot reply channel:
//! results are never reordered, and a worker that finishes early waits for nobody.
use std::collections::VecDeque;
use std::sync::mpsc::{self, Receiver, SyncSender};
use std::sync::Mutex;

/// Runs the map; stops at the first error of `produce` or `consume` (the workers then stop at
/// their next hand-over). `lost` is the error when a worker died without a result (a panic,
/// which `std::thread::scope` then re-raises).
pub(crate) fn ordered_map<J, R, S, E>(
    threads: usize,
    max_in_flight: usize,
    mut produce: impl FnMut() -> Result<Option<J>, E>,
    new_state: impl Fn() -> S + Sync,
    work: impl Fn(&mut S, J) -> R + Sync,
    mut consume: impl FnMut(R) -> Result<(), E>,
    lost: impl Fn() -> E,
) -> Result<(), E>
where
    J: Send,
    R: Send,
{
    let (job_tx, job_rx) = mpsc::channel::<(J, SyncSender<R>)>();
    let job_rx = Mutex::new(job_rx);
    std::thread::scope(|scope| {
        for _ in 0..threads.max(1) {
            let (job_rx, new_state, work) = (&job_rx, &new_state, &work);
            scope.spawn(move || {
                let mut state = new_state();
                loop {
                    // Hold the lock only to take a job, not while working on it.
                    let next = match job_rx.lock() {
                        Ok(rx) => rx.recv(),
                        Err(_) => return,
                    };
                    let Ok((job, reply)) = next else { return };
                    if reply.send(work(&mut state, job)).is_err() {
                        return; // the calling thread stopped (an error)
                    }
                }
            });
        }
        // Owned by this closure: dropped when it returns, which ends the workers' loops.
        let job_tx = job_tx;
        let mut pending: VecDeque<Receiver<R>> = VecDeque::new();
        let mut more = true;
        loop {
            while more && pending.len() < max_in_flight.max(1) {
                match produce()? {
                    Some(job) => {
                        let (reply, result) = mpsc::sync_channel(1);
                        job_tx.send((job, reply)).map_err(|_| lost())?;
                        pending.push_back(result);
                    }
                    None => more = false,
                }
            }
            let Some(next) = pending.pop_front() else {
                return Ok(());
            };
            consume(next.recv().map_err(|_| lost())?)?;
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn results_come_back_in_job_order_whatever_the_threads() {
        for threads in [1, 2, 4, 7] {
            let mut next = 0u64;
            let mut seen = Vec::new();
            ordered_map(
                threads,
                2 * threads + 2,
                || {
                    next += 1;
                    Ok::<_, String>((next <= 200).then_some(next))
                },
                || (),
                // Later jobs finish sooner: order must come from the hand-back, not from luck.
                |_, j| {
                    std::thread::sleep(std::time::Duration::from_micros(200 - j.min(200)));
                    j * 10
                },
                |r| {
                    seen.push(r);
                    Ok(())
                },
                || "lost".to_string(),
            )
            .unwrap();
            assert_eq!(seen, (1..=200).map(|j| j * 10).collect::<Vec<_>>());
        }
    }

    #[test]
    fn never_more_than_max_in_flight_jobs_are_out() {
        use std::sync::atomic::{AtomicUsize, Ordering};
        let out = AtomicUsize::new(0);
        let mut peak = 0;
        let mut made = 0;
        ordered_map(
            3,
            5,
            || {
                made += 1;
                peak = peak.max(out.fetch_add(1, Ordering::SeqCst) + 1);
                Ok::<_, ()>((made <= 100).then_some(made))
            },
            || (),
            |_, j| j,
            |_| {
                out.fetch_sub(1, Ordering::SeqCst);
                Ok(())
            },
            || (),
        )
        .unwrap();
        // The end-of-input call counts once too.
        assert!(peak <= 6, "{peak} jobs out at once");
    }

    #[test]
    fn an_error_while_consuming_stops_the_run() {
        let mut next = 0u64;
        let mut consumed = 0;
        let result = ordered_map(
            2,
            6,
            || {
                next += 1;
                Ok((next <= 1_000_000).then_some(next))
            },
            || (),
            |_, j| j,
            |r| {
                consumed += 1;
                if r == 10 {
                    return Err("stop at 10");
                }
                Ok(())
            },
            || "lost",
        );
        assert_eq!(result, Err("stop at 10"));
        assert_eq!(consumed, 10);
        assert!(next < 100, "kept producing after the error: {next}");
    }
}
