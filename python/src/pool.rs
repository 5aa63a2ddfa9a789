//! The thread pool the kernels run on: a rayon pool made by this process, not rayon's global one.
//!
//! A process forked after its parent ran a kernel (`multiprocessing` with the "fork" start
//! method, the default on Linux before Python 3.14; a `ProcessPoolExecutor`) inherits rayon's
//! global pool without its threads: its first parallel call would wait for them forever. The
//! pool here belongs to the process that built it; a forked child builds its own on first use.
use std::sync::{Arc, Mutex};

use rayon::ThreadPool;

use crate::errors::Failure;

/// The pool and the id of the process that built it.
static POOL: Mutex<Option<(u32, Arc<ThreadPool>)>> = Mutex::new(None);

/// This process's pool (`RAYON_NUM_THREADS` threads, else one per core), built on first use.
fn pool() -> Result<Arc<ThreadPool>, Failure> {
    let mut slot = POOL.lock().unwrap_or_else(|poisoned| poisoned.into_inner());
    let pid = std::process::id();
    if let Some((owner, pool)) = slot.as_ref() {
        if *owner == pid {
            return Ok(Arc::clone(pool));
        }
    }
    // Inherited from the parent through fork: its threads do not exist here, so it is never
    // dropped (dropping would signal them).
    if let Some(inherited) = slot.take() {
        std::mem::forget(inherited);
    }
    let pool = Arc::new(
        rayon::ThreadPoolBuilder::new()
            .thread_name(|k| format!("riskscore-{k}"))
            .build()
            .map_err(|e| Failure::Threads(format!("cannot start the scoring threads: {e}")))?,
    );
    *slot = Some((pid, Arc::clone(&pool)));
    Ok(pool)
}

/// Runs `work` in this process's pool: its `par_iter`s and `rayon::current_num_threads` use it.
pub fn install<R: Send>(work: impl FnOnce() -> R + Send) -> Result<R, Failure> {
    Ok(pool()?.install(work))
}
