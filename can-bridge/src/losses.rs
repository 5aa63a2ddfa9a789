//! What a run over a log lost, line by line, and the `--max-lost` verdict: lines the reader could
//! not use, frames the engine dropped (late, off the timeline, not decodable) and frames `replay`
//! could not send. Each kind keeps its first [`KEPT_PER_KIND`] lines and counts the rest, so a
//! log of millions of bad frames prints a few dozen lines.
use crate::engine::Output;
use crate::logfile::{LogReport, KEPT_PER_KIND};
use std::collections::BTreeMap;
use std::path::Path;

/// One lost frame: its log line, the kind of loss and why.
#[derive(Clone, Debug, PartialEq)]
pub struct LostFrame {
    pub line: u64,
    pub kind: &'static str,
    pub reason: String,
}

/// Frames of a log that were read but lost afterwards.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FrameLosses {
    /// The first [`KEPT_PER_KIND`] of each kind, in the order they were lost.
    pub kept: Vec<LostFrame>,
    /// Every lost frame, counted by kind.
    pub by_kind: BTreeMap<&'static str, u64>,
}

impl FrameLosses {
    /// Records the frame of `line` as lost; `reason` is only built for the kept ones.
    pub fn record(&mut self, line: u64, kind: &'static str, reason: impl FnOnce() -> String) {
        let n = self.by_kind.entry(kind).or_insert(0);
        *n += 1;
        if *n <= KEPT_PER_KIND as u64 {
            self.kept.push(LostFrame {
                line,
                kind,
                reason: reason(),
            });
        }
    }

    /// Records an engine output that reports a lost frame; ignores the others.
    pub fn handle(&mut self, output: &Output) {
        if let Output::Problem {
            reason,
            source,
            lost: Some(kind),
            ..
        } = output
        {
            self.record(*source, kind.as_str(), || reason.to_string());
        }
    }

    /// Frames lost, all kinds.
    pub fn total(&self) -> u64 {
        self.by_kind.values().sum()
    }

    /// Frames lost of one kind.
    pub fn count(&self, kind: &str) -> u64 {
        self.by_kind.get(kind).copied().unwrap_or(0)
    }

    /// Prints the kept losses as `FILE:LINE: reason` (in line order; `<stdin>:LINE:` for `-`,
    /// [`crate::logfile::line_name`]) on stderr, then one count per kind of those not printed.
    pub fn print(&self, path: &Path) {
        let name = crate::logfile::line_name(path);
        let mut kept: Vec<&LostFrame> = self.kept.iter().collect();
        kept.sort_by_key(|l| l.line);
        for l in kept {
            eprintln!("{name}:{}: {}", l.line, l.reason);
        }
        for (kind, n) in &self.by_kind {
            if *n > KEPT_PER_KIND as u64 {
                eprintln!(
                    "{name}: ... {} more {kind} not listed",
                    n - KEPT_PER_KIND as u64
                );
            }
        }
    }
}

/// More of a log was lost than `--max-lost` allows.
#[derive(Debug, thiserror::Error)]
#[error("{summary}; more than --max-lost {max_lost}")]
pub struct TooMuchLost {
    pub summary: String,
    pub max_lost: f64,
}

/// `FILE: lost N of M lines (P%): ...` (`<stdin>: ...` for `-`) with a count per kind, or `None`
/// when nothing was lost.
pub fn summary(path: &Path, report: &LogReport, frames: &FrameLosses) -> Option<(String, f64)> {
    let unreadable = report.bad_lines() as u64;
    let lost = unreadable + frames.total();
    if lost == 0 {
        return None;
    }
    let total = report.lines.saturating_sub(report.blank) as u64;
    let share = lost as f64 / total.max(1) as f64;
    let mut parts = vec![format!("{unreadable} unreadable lines")];
    parts.extend(frames.by_kind.iter().map(|(kind, n)| format!("{n} {kind}")));
    Some((
        format!(
            "{}: lost {lost} of {total} lines ({:.3}%): {}",
            crate::logfile::line_name(path),
            share * 100.0,
            parts.join(", ")
        ),
        share,
    ))
}

/// Prints every loss by line and the summary; fails when more than `max_lost` (a share of the
/// log's non-blank lines) is lost.
pub fn account(
    path: &Path,
    report: &LogReport,
    frames: &FrameLosses,
    max_lost: f64,
) -> Result<(), TooMuchLost> {
    print_lost(path, report, frames);
    verdict(path, report, frames, max_lost)
}

/// Prints every loss by line (unreadable lines, then lost frames) on stderr.
pub fn print_lost(path: &Path, report: &LogReport, frames: &FrameLosses) {
    report.print_bad_lines(path);
    frames.print(path);
}

/// The summary and the `--max-lost` verdict of [`account`], without the lines (printed before
/// with [`print_lost`]).
pub fn verdict(
    path: &Path,
    report: &LogReport,
    frames: &FrameLosses,
    max_lost: f64,
) -> Result<(), TooMuchLost> {
    let Some((summary, share)) = summary(path, report, frames) else {
        return Ok(());
    };
    if share > max_lost {
        return Err(TooMuchLost { summary, max_lost });
    }
    eprintln!("can-bridge: {summary} (within --max-lost {max_lost})");
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::engine::{LossKind, Problem};

    #[test]
    fn losses_are_kept_per_kind_counted_and_judged_against_the_allowance() {
        let mut frames = FrameLosses::default();
        for line in 1..=100 {
            frames.handle(&Output::Problem {
                t_us: line,
                source: line,
                reason: Problem::BadState { track: line as u32 },
                lost: Some(LossKind::Decode),
            });
        }
        // Not a loss: no `lost`.
        frames.handle(&Output::Problem {
            t_us: 0,
            source: 0,
            reason: Problem::ValidFlagMissing { track: 0 },
            lost: None,
        });
        frames.record(7, LossKind::Late.as_str(), || "late".into());
        assert_eq!(frames.total(), 101);
        assert_eq!(frames.count("frames not decodable"), 100);
        assert_eq!(frames.kept.len(), KEPT_PER_KIND + 1);
        let report = LogReport {
            lines: 10_100,
            frames: 10_100,
            ..LogReport::default()
        };
        let (text, share) = summary(Path::new("d.log"), &report, &frames).unwrap();
        assert_eq!(
            text,
            "d.log: lost 101 of 10100 lines (1.000%): 0 unreadable lines, 100 frames not decodable, 1 late frames"
        );
        assert!((share - 0.01).abs() < 1e-12);
        assert!(account(Path::new("d.log"), &report, &frames, 0.01).is_ok());
        let e = account(Path::new("d.log"), &report, &frames, 0.005).unwrap_err();
        assert!(e.to_string().ends_with("more than --max-lost 0.005"), "{e}");
        assert!(summary(Path::new("d.log"), &report, &FrameLosses::default()).is_none());
    }
}
