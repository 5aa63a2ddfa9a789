//! Warning and data-freshness parameters of the engine, and the table size it holds.
use scorer_core::warning::{WarningConfig, WarningError};

/// Most tracks held at once (radars report up to 64-100 objects).
pub const MAX_TRACKS: usize = 128;

/// Warning and data-freshness parameters.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EngineConfig {
    /// Warn when the score is `>= threshold`.
    pub threshold: f32,
    /// Level 2 ("urgent") when the score is `>= urgent`.
    pub urgent: Option<f32>,
    /// Release when the score falls below `threshold - hysteresis` (live mode).
    pub hysteresis: f32,
    /// A warning stays on at least this long (live mode).
    pub min_on_us: u64,
    /// Data older than this is stale; tracks not updated for this long are dropped.
    pub stale_us: u64,
    /// Latched warnings (evaluation semantics): never released while the track lives.
    pub latch: bool,
}

impl EngineConfig {
    pub fn new(threshold: f32) -> Self {
        Self {
            threshold,
            urgent: None,
            hysteresis: 0.0,
            min_on_us: 500_000,
            stale_us: 500_000,
            latch: false,
        }
    }

    pub(super) fn warning_config(&self) -> WarningConfig {
        if self.latch {
            WarningConfig::first_threshold(self.threshold, self.stale_us)
        } else {
            WarningConfig::live(
                self.threshold,
                self.hysteresis,
                self.min_on_us,
                self.stale_us,
            )
        }
    }
}

/// The engine refused its configuration.
#[derive(Debug, thiserror::Error)]
#[error("warning configuration")]
pub struct ConfigError(#[source] pub WarningError);
