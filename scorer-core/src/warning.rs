//! Warning decisions: the first-threshold rule of the evaluation protocol, and a fixed-capacity
//! per-partner track table for live use.
//!
//! Time is `u64` microseconds (monotonic, any epoch): integer time never drifts, compares exactly
//! and covers 584 000 years. CAN timestamps are microseconds already.
//!
//! Rule ([`FirstThreshold`], and each track of [`TrackTable`]): the warning turns on at the first
//! update with `R >= threshold` (inclusive, exactly as evaluation counts an alert; NaN never
//! triggers). In *latched* mode (evaluation semantics) it then stays on for the life of the track.
//! In *live* mode it is released at the first update with `R < threshold - hysteresis` once it has
//! been on for at least `min_on_us`; a later crossing is a new onset.
//!
//! Table ([`TrackTable`]): tracks keyed by partner id (`u32`), at most `N`, stored in a
//! `heapless::Vec` in insertion order (so every operation is deterministic).
//! - Staleness: a track whose last update is more than `stale_after_us` away from `now` is stale:
//!   before `now` (not updated for too long), or after it (the time base was reset). Stale tracks
//!   are never reported as warning by the query functions. [`TrackTable::expire`] (also run by
//!   every [`TrackTable::update`]) drops the tracks not updated for too long
//!   ([`Track::is_expired`]); a track whose last update lies ahead of `now` is dropped only by an
//!   update of its own id (the time base was reset: it starts afresh) or by eviction, so one
//!   update with a bogus early time cannot clear the other tracks.
//! - Id reuse: an id whose track was dropped (stale, [`TrackTable::remove`], eviction) starts a fresh
//!   track: no latched warning, no history.
//! - Table full (after dropping the expired tracks): [`FullPolicy::Reject`] returns
//!   [`WarningError::TableFull`]; [`FullPolicy::EvictLeastRecent`] evicts the least recently updated
//!   track that is *not* warning (lowest slot on ties) and returns `TableFull` only when every track
//!   is warning. An active warning is never evicted (nor a warning track left ahead of `now` by a
//!   clock reset: it is restarted by its own id's next update, or removed).
//! - An update older than its track's last update by at most `stale_after_us` is rejected
//!   ([`WarningError::OutOfOrder`]) and changes nothing; older by more, it restarts that track
//!   (above); a NaN score is rejected ([`WarningError::NonFiniteScore`]) and changes nothing
//!   (the track then goes stale if no valid score follows). `+inf` is a valid, maximal score and
//!   `-inf` a valid, minimal one (what each does: [`WarningError::NonFiniteScore`]).
//!
//! After a time-base reset the caller should [`TrackTable::clear`] the table (or remove the
//! tracks), as the C ABI asks of its integrators. Tracks left ahead of `now` are never reported as
//! warning, never expired, and a warning one is never evicted: a table full of them refuses every
//! new partner with [`WarningError::TableFull`] until the clock passes their old times, and the
//! non-warning ones are evicted last, after the live partners.
//!
//! ```
//! use scorer_core::warning::{TrackTable, WarningConfig, WarningError};
//!
//! let mut table = TrackTable::<2>::new(WarningConfig::live(1.0, 0.0, 0, 1_000_000))?;
//! table.update(1, 5_000_000_000, 5.0)?; // two warnings, 5 000 s after start-up
//! table.update(2, 5_000_000_000, 5.0)?;
//! // The timer restarts at 0; partners 1 and 2 are gone, a new one closes in.
//! assert_eq!(table.update(3, 100, 5.0), Err(WarningError::TableFull { id: 3 }));
//! assert!(!table.any_warning(100));
//! table.clear(); // on the reset
//! assert!(table.update(3, 100, 5.0)?.warning);
//! # Ok::<(), WarningError>(())
//! ```

use core::fmt;

/// Microseconds.
pub type Micros = u64;

/// The evaluation protocol's per-sequence rule: warn at the first update with `R >= threshold`,
/// then stay warned.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FirstThreshold {
    threshold: f32,
    updates: u32,
    first: Option<u32>,
}

impl FirstThreshold {
    /// A fresh sequence.
    pub const fn new(threshold: f32) -> Self {
        Self {
            threshold,
            updates: 0,
            first: None,
        }
    }

    /// Feeds the next score; returns whether the warning is on after it.
    pub fn update(&mut self, r: f32) -> bool {
        if self.first.is_none() && r >= self.threshold {
            self.first = Some(self.updates);
        }
        self.updates = self.updates.saturating_add(1);
        self.first.is_some()
    }

    /// Whether the warning has been given.
    pub fn is_warning(&self) -> bool {
        self.first.is_some()
    }

    /// 0-based index of the update that triggered the warning.
    pub fn first_warning(&self) -> Option<u32> {
        self.first
    }

    /// Number of updates fed.
    pub fn updates(&self) -> u32 {
        self.updates
    }

    /// The threshold.
    pub fn threshold(&self) -> f32 {
        self.threshold
    }

    /// Starts a new sequence (same threshold).
    pub fn reset(&mut self) {
        *self = Self::new(self.threshold);
    }
}

/// Index of the first score `>= threshold` in a sequence (the evaluation's alert frame).
pub fn first_crossing<I: IntoIterator<Item = f32>>(scores: I, threshold: f32) -> Option<usize> {
    scores.into_iter().position(|r| r >= threshold)
}

/// What to do when a new id arrives and the table is full of fresh tracks.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FullPolicy {
    /// Refuse the new id with [`WarningError::TableFull`].
    Reject,
    /// Evict the least recently updated non-warning track; refuse only if all tracks warn.
    EvictLeastRecent,
}

/// Parameters of the per-track rule and of the table.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WarningConfig {
    /// Warn when `R >= threshold`. Finite: NaN, `+inf` and `-inf` are refused by
    /// [`WarningConfig::validate`].
    pub threshold: f32,
    /// `true`: latched (evaluation semantics, never released). `false`: live mode.
    pub latch: bool,
    /// Live mode: release when `R < threshold - hysteresis` (`>= 0`, and small enough that
    /// `threshold - hysteresis` is finite: [`WarningConfig::validate`]).
    pub hysteresis: f32,
    /// Live mode: a warning stays on at least this long.
    pub min_on_us: Micros,
    /// Tracks not updated for longer than this are stale and dropped (`u64::MAX`: never). At
    /// least 1: 0 is refused by [`WarningConfig::validate`] (every track would be stale at the
    /// next tick, silently disabling the warnings).
    pub stale_after_us: Micros,
    /// Table-full behaviour.
    pub when_full: FullPolicy,
}

impl WarningConfig {
    /// Evaluation semantics: latched first-threshold warning, evict-least-recent when full.
    pub const fn first_threshold(threshold: f32, stale_after_us: Micros) -> Self {
        Self {
            threshold,
            latch: true,
            hysteresis: 0.0,
            min_on_us: 0,
            stale_after_us,
            when_full: FullPolicy::EvictLeastRecent,
        }
    }

    /// Live use: release below `threshold - hysteresis` after at least `min_on_us`.
    pub const fn live(
        threshold: f32,
        hysteresis: f32,
        min_on_us: Micros,
        stale_after_us: Micros,
    ) -> Self {
        Self {
            threshold,
            latch: false,
            hysteresis,
            min_on_us,
            stale_after_us,
            when_full: FullPolicy::EvictLeastRecent,
        }
    }

    /// Refuses ([`WarningError::InvalidConfig`], naming the field) what is invalid or would
    /// silently disable the warnings, as the C ABI's `riskscore_init` does:
    /// - a `threshold` that is not finite: NaN; `+inf`, at which no finite score ever warns;
    ///   `-inf`, at which every partner warns at once and is never released;
    /// - a `hysteresis` that is negative or not finite;
    /// - a `hysteresis` so large that the release level `threshold - hysteresis` overflows to
    ///   `-inf` (a very negative threshold): no score is below `-inf`, so a live warning could
    ///   never be released (refused whatever the mode);
    /// - a `stale_after_us` of 0: every track would be stale as soon as the clock moves on, so no
    ///   warning outlives the next tick and every update of a partner starts a new track (use a
    ///   positive window; `u64::MAX` is "never stale").
    ///
    /// ```
    /// use scorer_core::warning::{WarningConfig, WarningError};
    ///
    /// assert!(WarningConfig::live(2.0, 0.1, 0, 1).validate().is_ok());
    /// for bad in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
    ///     let refused = WarningConfig::first_threshold(bad, 1_000_000).validate();
    ///     assert!(matches!(refused, Err(WarningError::InvalidConfig(_))));
    /// }
    /// assert!(WarningConfig::first_threshold(2.0, 0).validate().is_err());
    /// assert!(WarningConfig::live(f32::MIN, f32::MAX, 0, 1).validate().is_err());
    /// ```
    pub fn validate(&self) -> Result<(), WarningError> {
        if !self.threshold.is_finite() {
            return Err(WarningError::InvalidConfig(
                "threshold must be finite (NaN, +inf and -inf are refused)",
            ));
        }
        if !(self.hysteresis.is_finite() && self.hysteresis >= 0.0) {
            return Err(WarningError::InvalidConfig(
                "hysteresis must be finite and >= 0",
            ));
        }
        // With both finite, only a huge hysteresis under a very negative threshold overflows,
        // to -inf: no score is below that, so a live warning would never be released.
        if !(self.threshold - self.hysteresis).is_finite() {
            return Err(WarningError::InvalidConfig(
                "threshold - hysteresis (the release level) must be finite, not -inf",
            ));
        }
        if self.stale_after_us == 0 {
            return Err(WarningError::InvalidConfig(
                "stale_after_us must be > 0 (u64::MAX: never stale)",
            ));
        }
        Ok(())
    }
}

/// Rejected table operations.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum WarningError {
    /// The score was NaN (any NaN, whatever its sign or payload): despite the name, the only
    /// score [`TrackTable::update`] refuses. It is checked first, so the refused call changes
    /// nothing at all, not even the drop of expired tracks every accepted update does; the
    /// track keeps its last update time and goes stale if no valid score follows.
    ///
    /// Infinite scores are not refused: they are accepted updates like any finite score (the
    /// track's `last_update_us` and `last_score` are set, `updates` counts it, a new id gets a
    /// track), compared with the threshold as IEEE floats:
    ///
    /// - `+inf` is the maximal score: it turns a warning on at once (`>= threshold` holds for
    ///   every threshold, which [`WarningConfig::validate`] keeps finite) and never releases one.
    /// - `-inf` is the minimal score: it never turns a warning on. In live mode it releases a
    ///   warning that has been on for at least `min_on_us` (it is below `threshold -
    ///   hysteresis`, which [`WarningConfig::validate`] keeps finite); latched, the warning stays
    ///   on.
    ///
    /// [`FirstThreshold::update`] reads them the same way (NaN never triggers, `+inf` does).
    /// This example runs as a doctest, as does `tests/warning.rs`
    /// (`infinite_scores_are_accepted_updates`), so the description cannot drift:
    ///
    /// ```
    /// use scorer_core::warning::{TrackTable, WarningConfig, WarningError, WarningEvent};
    ///
    /// // Live: warn at 2.0, release below 1.9 after 0.5 s on; stale after 1 s.
    /// let mut table = TrackTable::<4>::new(WarningConfig::live(2.0, 0.1, 500_000, 1_000_000))?;
    /// let event = |t: &mut TrackTable<4>, now, r| t.update(1, now, r).map(|s| (s.warning, s.event));
    ///
    /// // NaN: refused, no track created.
    /// assert_eq!(table.update(1, 0, f32::NAN), Err(WarningError::NonFiniteScore { id: 1 }));
    /// assert!(table.get(1).is_none());
    /// // -inf: accepted (a new track), no onset.
    /// assert_eq!(event(&mut table, 0, f32::NEG_INFINITY), Ok((false, WarningEvent::None)));
    /// // +inf: accepted, onset; held by a later -inf until the warning has been on for 0.5 s.
    /// assert_eq!(event(&mut table, 100_000, f32::INFINITY), Ok((true, WarningEvent::Onset)));
    /// assert_eq!(event(&mut table, 200_000, f32::NEG_INFINITY), Ok((true, WarningEvent::None)));
    /// assert_eq!(event(&mut table, 600_000, f32::NEG_INFINITY), Ok((false, WarningEvent::Release)));
    /// let track = table.get(1).copied().expect("held");
    /// assert_eq!((track.last_score, track.updates, track.onsets), (f32::NEG_INFINITY, 4, 1));
    ///
    /// // Latched: -inf does not release.
    /// let mut latched = TrackTable::<4>::new(WarningConfig::first_threshold(2.0, 1_000_000))?;
    /// assert!(latched.update(1, 0, f32::INFINITY)?.warning);
    /// assert!(latched.update(1, 100_000, f32::NEG_INFINITY)?.warning);
    /// # Ok::<(), WarningError>(())
    /// ```
    NonFiniteScore {
        /// The partner id of the refused update.
        id: u32,
    },
    /// `now` is earlier than the track's last update, by at most the stale window (further back,
    /// the track is stale: see [`Track::is_stale`]).
    OutOfOrder {
        /// The partner id of the refused update.
        id: u32,
        /// The track's last accepted update time (us, the caller's monotonic clock).
        last_us: Micros,
        /// The refused update's time (us): before `last_us`, by at most
        /// [`WarningConfig::stale_after_us`].
        now_us: Micros,
    },
    /// No room for a new track (see [`FullPolicy`]).
    TableFull {
        /// The partner id that found no slot (nothing was evicted for it).
        id: u32,
    },
    /// A [`WarningConfig`] field is invalid.
    InvalidConfig(&'static str),
}

impl fmt::Display for WarningError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::NonFiniteScore { id } => write!(f, "track {id}: score is NaN"),
            Self::OutOfOrder {
                id,
                last_us,
                now_us,
            } => {
                write!(
                    f,
                    "track {id}: update at {now_us} us is older than the last one at {last_us} us"
                )
            }
            Self::TableFull { id } => write!(f, "track {id}: track table full"),
            Self::InvalidConfig(why) => write!(f, "invalid warning config: {why}"),
        }
    }
}

impl core::error::Error for WarningError {}

/// What an update changed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum WarningEvent {
    /// The warning state did not change.
    None,
    /// The warning turned on at this update.
    Onset,
    /// The warning was released at this update (live mode only).
    Release,
}

/// One partner's warning state.
///
/// 56 bytes on 32- and 64-bit targets: the two optional times are stored as plain `u64` and are
/// meaningful only when their flag says so (`on_since_us` while `warning`, `first_warning_us` once
/// `onsets > 0`), so no `Option<u64>` (16 bytes each) and no sentinel that a real time could
/// collide with. Read them with [`Track::on_since_us`] and [`Track::first_warning_us`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Track {
    /// Partner id.
    pub id: u32,
    /// Time of the track's first update.
    pub created_us: Micros,
    /// Time of the last accepted update.
    pub last_update_us: Micros,
    /// Last accepted score (never NaN; may be `+inf` or `-inf`, see
    /// [`WarningError::NonFiniteScore`]).
    pub last_score: f32,
    /// Whether the warning is on.
    pub warning: bool,
    /// When the current warning turned on; valid while `warning`, else 0.
    on_since: Micros,
    /// When this track first warned; valid once `onsets > 0`, else 0.
    first_warning: Micros,
    /// Number of accepted updates.
    pub updates: u32,
    /// Number of onsets (1 at most when latched).
    pub onsets: u32,
}

// The ECU budget is 64 bytes per track (docs/ecu.md); 56 on 32- and 64-bit targets.
const _: () = assert!(core::mem::size_of::<Track>() <= 64);

impl Track {
    fn new(id: u32, now: Micros) -> Self {
        Self {
            id,
            created_us: now,
            last_update_us: now,
            last_score: 0.0,
            warning: false,
            on_since: 0,
            first_warning: 0,
            updates: 0,
            onsets: 0,
        }
    }

    /// When the current warning turned on (`None` while not warning).
    pub fn on_since_us(&self) -> Option<Micros> {
        self.warning.then_some(self.on_since)
    }

    /// When this track first warned, the first-threshold alert time (`None` if it never warned).
    pub fn first_warning_us(&self) -> Option<Micros> {
        (self.onsets > 0).then_some(self.first_warning)
    }

    /// Whether the track is stale at `now`: its last update lies more than `stale_after` away from
    /// `now`, in either direction. A `now` more than the window *before* the last update means the
    /// time base was reset (ECU timer re-init, a wrapped counter): the track is stale, so the next
    /// update drops it and starts a new track instead of returning
    /// [`WarningError::OutOfOrder`] until the clock catches up. A step back within the window is
    /// an out-of-order update (the track stays fresh and the update is refused).
    pub fn is_stale(&self, now: Micros, stale_after: Micros) -> bool {
        now.abs_diff(self.last_update_us) > stale_after
    }

    /// Whether the track was not updated for more than `stale_after` before `now`: what
    /// [`TrackTable::expire`] drops. The stale tracks whose last update lies ahead of `now` are
    /// not expired (see the module's staleness rule).
    pub fn is_expired(&self, now: Micros, stale_after: Micros) -> bool {
        now.saturating_sub(self.last_update_us) > stale_after
    }

    fn apply(&mut self, cfg: &WarningConfig, now: Micros, r: f32) -> WarningEvent {
        self.last_update_us = now;
        self.last_score = r;
        self.updates = self.updates.saturating_add(1);
        if !self.warning {
            if r >= cfg.threshold {
                self.warning = true;
                self.on_since = now;
                if self.onsets == 0 {
                    self.first_warning = now;
                }
                // Saturating: never returns to 0, so `first_warning` stays valid.
                self.onsets = self.onsets.saturating_add(1);
                return WarningEvent::Onset;
            }
            return WarningEvent::None;
        }
        if !cfg.latch {
            let on_for = now.saturating_sub(self.on_since);
            if r < cfg.threshold - cfg.hysteresis && on_for >= cfg.min_on_us {
                self.warning = false;
                self.on_since = 0;
                return WarningEvent::Release;
            }
        }
        WarningEvent::None
    }
}

/// Result of [`TrackTable::update`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TrackStatus {
    /// Whether the partner's warning is on after this update.
    pub warning: bool,
    /// What changed.
    pub event: WarningEvent,
    /// True when this update created the track (new id, or a reused id after a drop).
    pub new_track: bool,
    /// Id of a track evicted to make room, if any.
    pub evicted: Option<u32>,
}

/// Up to `N` partner tracks; no allocation.
///
/// The live rule of the module documentation, step by step (times in microseconds):
///
/// ```
/// use scorer_core::warning::{TrackTable, WarningConfig, WarningError, WarningEvent};
///
/// // Warn at R >= 2.0; release below 1.9 once on for 0.5 s; a track silent for 1 s is stale.
/// let mut table = TrackTable::<8>::new(WarningConfig::live(2.0, 0.1, 500_000, 1_000_000))?;
/// let event = |t: &mut TrackTable<8>, now, r| t.update(7, now, r).map(|s| s.event);
///
/// assert_eq!(event(&mut table, 0, 1.0), Ok(WarningEvent::None));
/// assert_eq!(event(&mut table, 100_000, 2.0), Ok(WarningEvent::Onset)); // inclusive
/// assert_eq!(event(&mut table, 200_000, 0.0), Ok(WarningEvent::None)); // held: on for 0.1 s
/// assert_eq!(event(&mut table, 600_000, 1.95), Ok(WarningEvent::None)); // within the hysteresis
/// assert_eq!(event(&mut table, 600_000, 1.85), Ok(WarningEvent::Release)); // 0.5 s on, below 1.9
/// assert!(!table.is_warning(7, 600_000));
///
/// // Refused, changing nothing: a NaN score, a step back in time within the stale window.
/// assert_eq!(table.update(7, 700_000, f32::NAN), Err(WarningError::NonFiniteScore { id: 7 }));
/// assert!(matches!(table.update(7, 500_000, 3.0), Err(WarningError::OutOfOrder { .. })));
///
/// // Silent for more than 1 s: never reported as warning, dropped by the next update.
/// assert_eq!(event(&mut table, 700_000, 5.0), Ok(WarningEvent::Onset));
/// assert!(table.is_warning(7, 1_700_000) && !table.is_warning(7, 1_700_001));
/// let status = table.update(9, 1_700_001, 0.0)?;
/// assert!(status.new_track && table.get(7).is_none());
/// # Ok::<(), WarningError>(())
/// ```
#[derive(Clone, Debug)]
pub struct TrackTable<const N: usize> {
    config: WarningConfig,
    tracks: heapless::Vec<Track, N>,
}

impl<const N: usize> TrackTable<N> {
    /// An empty table; `Err(InvalidConfig)` for a config [`WarningConfig::validate`] refuses
    /// (a threshold that is not finite, a negative or non-finite hysteresis, a `threshold -
    /// hysteresis` that overflows to `-inf`, a `stale_after_us` of 0).
    pub fn new(config: WarningConfig) -> Result<Self, WarningError> {
        config.validate()?;
        Ok(Self {
            config,
            tracks: heapless::Vec::new(),
        })
    }

    /// The configuration.
    pub fn config(&self) -> &WarningConfig {
        &self.config
    }

    /// Number of tracks held (stale ones included until the next `expire`/`update`).
    pub fn len(&self) -> usize {
        self.tracks.len()
    }

    /// True when no track is held.
    pub fn is_empty(&self) -> bool {
        self.tracks.is_empty()
    }

    /// Capacity `N`.
    pub const fn capacity(&self) -> usize {
        N
    }

    /// All held tracks in insertion order.
    pub fn iter(&self) -> impl Iterator<Item = &Track> {
        self.tracks.iter()
    }

    /// The track of `id`, if held (possibly stale).
    pub fn get(&self, id: u32) -> Option<&Track> {
        self.tracks.iter().find(|t| t.id == id)
    }

    /// Drops the tracks not updated for more than the stale window before `now`
    /// ([`Track::is_expired`]); returns how many.
    pub fn expire(&mut self, now: Micros) -> usize {
        let before = self.tracks.len();
        let stale_after = self.config.stale_after_us;
        self.tracks.retain(|t| !t.is_expired(now, stale_after));
        before - self.tracks.len()
    }

    /// Drops the track of `id`; returns whether it existed.
    pub fn remove(&mut self, id: u32) -> bool {
        let before = self.tracks.len();
        self.tracks.retain(|t| t.id != id);
        before != self.tracks.len()
    }

    /// Drops every track.
    pub fn clear(&mut self) {
        self.tracks.clear();
    }

    /// Whether `id` is warning at `now` (false if unknown or stale).
    pub fn is_warning(&self, id: u32, now: Micros) -> bool {
        self.get(id)
            .is_some_and(|t| t.warning && !t.is_stale(now, self.config.stale_after_us))
    }

    /// Fresh (non-stale) tracks that are warning at `now`, in insertion order.
    pub fn warnings(&self, now: Micros) -> impl Iterator<Item = &Track> {
        let stale_after = self.config.stale_after_us;
        self.tracks
            .iter()
            .filter(move |t| t.warning && !t.is_stale(now, stale_after))
    }

    /// True if any fresh track is warning at `now`.
    pub fn any_warning(&self, now: Micros) -> bool {
        self.warnings(now).next().is_some()
    }

    /// Feeds the score `r` of partner `id` at time `now`: drops the expired tracks
    /// ([`TrackTable::expire`]; not the stale ones ahead of `now`), finds or creates the partner's
    /// track, applies the rule. Errors change nothing but that drop.
    ///
    /// Time runs forward: `now` earlier than the track's last update by at most
    /// `stale_after_us` is refused with [`WarningError::OutOfOrder`]; earlier by more means the
    /// time base was reset, so the track is stale ([`Track::is_stale`]) and the update restarts it
    /// in its slot as a new track (a warning that was on is not carried over the reset). The other tracks
    /// are left as they are: an update of one id never drops another for lying ahead of `now`.
    pub fn update(&mut self, id: u32, now: Micros, r: f32) -> Result<TrackStatus, WarningError> {
        if r.is_nan() {
            return Err(WarningError::NonFiniteScore { id });
        }
        self.expire(now);
        let cfg = self.config;
        if let Some(track) = self.tracks.iter_mut().find(|t| t.id == id) {
            let mut new_track = false;
            if now < track.last_update_us {
                if !track.is_stale(now, cfg.stale_after_us) {
                    return Err(WarningError::OutOfOrder {
                        id,
                        last_us: track.last_update_us,
                        now_us: now,
                    });
                }
                // The time base was reset: the track starts afresh, in its slot.
                *track = Track::new(id, now);
                new_track = true;
            }
            let event = track.apply(&cfg, now, r);
            return Ok(TrackStatus {
                warning: track.warning,
                event,
                new_track,
                evicted: None,
            });
        }
        let mut evicted = None;
        if self.tracks.is_full() {
            if cfg.when_full == FullPolicy::Reject {
                return Err(WarningError::TableFull { id });
            }
            let victim = self
                .tracks
                .iter()
                .filter(|t| !t.warning)
                .fold(None::<&Track>, |best, t| match best {
                    Some(b) if b.last_update_us <= t.last_update_us => Some(b),
                    _ => Some(t),
                })
                .map(|t| t.id);
            match victim {
                Some(v) => {
                    self.remove(v);
                    evicted = Some(v);
                }
                None => return Err(WarningError::TableFull { id }),
            }
        }
        let mut track = Track::new(id, now);
        let event = track.apply(&cfg, now, r);
        let warning = track.warning;
        self.tracks
            .push(track)
            .map_err(|_| WarningError::TableFull { id })?;
        Ok(TrackStatus {
            warning,
            event,
            new_track: true,
            evicted,
        })
    }
}
