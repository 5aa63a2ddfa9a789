//! Sizes a user sets, checked before anything is allocated, spawned or written: thread counts
//! against the cores, and a run's estimated memory or disk use against what the machine has now
//! (`MemAvailable` of /proc/meminfo, the free space of the output's file system). An allocation
//! that cannot succeed aborts the process; a run that would fill the disk fails hours later. Both
//! are cheaper to refuse up front, with the option to change named.
use std::path::Path;

/// A size a user set that this machine cannot honour.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum LimitError {
    #[error("{option} {value}: at most {max} ({why})")]
    AboveCap {
        option: String,
        value: u128,
        max: u128,
        why: String,
    },
    #[error(
        "{option} {value} needs about {} of {resource}, but only {} is available{where_}: \
         lower {option}",
        human_bytes(*needed),
        human_bytes(*available)
    )]
    DoesNotFit {
        option: String,
        value: u128,
        resource: &'static str,
        needed: u64,
        available: u64,
        /// " on the file system of PATH", or empty for memory.
        where_: String,
    },
}

/// Cores this process may use (1 when unknown).
pub fn cores() -> usize {
    std::thread::available_parallelism().map_or(1, |n| n.get())
}

/// The most worker threads a `--threads` option accepts: 4 per core. More only adds switching
/// and stacks (each thread reserves its own), and a count far above it cannot even be spawned.
pub fn max_threads() -> usize {
    4 * cores()
}

/// Check a `--threads` value (0 = one per core) and return the count to run.
pub fn check_threads(option: &str, threads: usize) -> Result<usize, LimitError> {
    let max = max_threads();
    match threads {
        0 => Ok(cores()),
        n if n <= max => Ok(n),
        n => Err(LimitError::AboveCap {
            option: option.to_string(),
            value: n as u128,
            max: max as u128,
            why: format!("4 threads per core, {} cores here", cores()),
        }),
    }
}

/// Check a count against a documented cap.
pub fn check_cap(option: &str, value: u128, max: u128, why: &str) -> Result<(), LimitError> {
    if value > max {
        return Err(LimitError::AboveCap {
            option: option.to_string(),
            value,
            max,
            why: why.to_string(),
        });
    }
    Ok(())
}

/// Memory the kernel says can be allocated now without swapping (`MemAvailable`), in bytes;
/// `None` where /proc/meminfo is not there (the check is then skipped).
pub fn memory_available() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    parse_mem_available(&text)
}

fn parse_mem_available(meminfo: &str) -> Option<u64> {
    let line = meminfo.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    kib.checked_mul(1024)
}

/// Free bytes (for an unprivileged user) on the file system that would hold `path`: that of its
/// nearest existing ancestor, since the output usually does not exist yet.
pub fn disk_available(path: &Path) -> Option<u64> {
    let absolute = std::path::absolute(path).ok()?;
    let existing = absolute.ancestors().find(|p| p.exists())?;
    let stat = rustix::fs::statvfs(existing).ok()?;
    stat.f_bavail.checked_mul(stat.f_frsize)
}

/// Refuse `option value` when its estimated memory use is more than is available now.
pub fn check_memory(option: &str, value: u128, needed: u64) -> Result<(), LimitError> {
    check_fits(
        option,
        value,
        "memory",
        needed,
        memory_available(),
        String::new(),
    )
}

/// Refuse `option value` when its estimated output is larger than the free space where `out`
/// is written.
pub fn check_disk(option: &str, value: u128, needed: u64, out: &Path) -> Result<(), LimitError> {
    check_fits(
        option,
        value,
        "disk space",
        needed,
        disk_available(out),
        format!(" on the file system of {}", out.display()),
    )
}

fn check_fits(
    option: &str,
    value: u128,
    resource: &'static str,
    needed: u64,
    available: Option<u64>,
    where_: String,
) -> Result<(), LimitError> {
    match available {
        Some(available) if needed > available => Err(LimitError::DoesNotFit {
            option: option.to_string(),
            value,
            resource,
            needed,
            available,
            where_,
        }),
        _ => Ok(()),
    }
}

/// `bytes` for people: B, KB, MB, GB, TB (powers of 1000, one decimal above KB).
pub fn human_bytes(bytes: u64) -> String {
    const UNITS: [&str; 5] = ["B", "KB", "MB", "GB", "TB"];
    let mut value = bytes as f64;
    let mut unit = 0;
    while value >= 1000.0 && unit + 1 < UNITS.len() {
        value /= 1000.0;
        unit += 1;
    }
    if unit == 0 {
        format!("{bytes} B")
    } else {
        format!("{value:.1} {}", UNITS[unit])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mem_available_is_read_in_bytes() {
        let meminfo =
            "MemTotal:       32000000 kB\nMemFree:  100 kB\nMemAvailable:   23925796 kB\n";
        assert_eq!(parse_mem_available(meminfo), Some(23_925_796 * 1024));
        assert_eq!(parse_mem_available("MemTotal: 5 kB\n"), None);
    }

    #[test]
    fn threads_above_four_per_core_are_refused_and_zero_means_one_per_core() {
        assert_eq!(check_threads("--threads", 0), Ok(cores()));
        assert_eq!(check_threads("--threads", 1), Ok(1));
        assert_eq!(check_threads("--threads", max_threads()), Ok(max_threads()));
        let err = check_threads("--threads", 100_000).unwrap_err().to_string();
        assert!(err.starts_with("--threads 100000: at most "), "{err}");
    }

    #[test]
    fn a_need_above_what_is_available_names_the_option_and_both_sizes() {
        let err = check_fits(
            "--events",
            7,
            "memory",
            2_500_000_000,
            Some(1_000_000),
            String::new(),
        )
        .unwrap_err()
        .to_string();
        assert_eq!(
            err,
            "--events 7 needs about 2.5 GB of memory, but only 1.0 MB is available: lower --events"
        );
        assert!(check_fits("--events", 7, "memory", 10, Some(10), String::new()).is_ok());
        // Unknown availability: no refusal on a guess.
        assert!(check_fits("--events", 7, "memory", u64::MAX, None, String::new()).is_ok());
    }

    #[test]
    fn free_space_is_found_for_a_path_that_does_not_exist_yet() {
        let dir = tempfile::tempdir().unwrap();
        assert!(disk_available(&dir.path().join("not/yet/there")).is_some_and(|b| b > 0));
    }
}
