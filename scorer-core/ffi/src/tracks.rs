//! The partner track table: warning updates, reading and dropping tracks, counting warnings.
use crate::convert::{event_code, opt_us, sat_u32, status, warning_error};
use crate::ptr::{context_mut, context_ref, write, write_optional};
use crate::types::{RiskscoreContext, RiskscoreStatus, RiskscoreTrack, RiskscoreTrackStatus};
use crate::RISKSCORE_NONE_U32;

/// Feeds the score `risk` of partner `track_id` at time `now_us` (monotonic microseconds) to the
/// track table: drops the tracks not updated for more than `stale_after_us` (not those left ahead
/// of `now_us` by a reset time base: only an update of their own id or a remove drops them), finds
/// or creates the partner's track, applies the warning rule. `out` may be NULL. On error nothing
/// changes except that drop. `track_id`
/// `RISKSCORE_NONE_U32` is refused (`RISKSCORE_STATUS_INVALID_INPUT`): it means "no track" in
/// `evicted_id`. A `now_us` before the track's last update by at most `stale_after_us` is refused
/// (`RISKSCORE_STATUS_OUT_OF_ORDER`); before it by more, the time base was reset: the track is
/// stale, is dropped, and the update starts a new track (the other tracks stay as they are).
///
/// # Safety
/// `context` must be NULL or initialised; `out` NULL or writable.
#[no_mangle]
pub unsafe extern "C" fn riskscore_track_update(
    context: *mut RiskscoreContext,
    track_id: u32,
    now_us: u64,
    risk: f32,
    out: *mut RiskscoreTrackStatus,
) -> RiskscoreStatus {
    let run = || {
        // SAFETY: caller contract above.
        let ctx = unsafe { context_mut(context) }?;
        if track_id == RISKSCORE_NONE_U32 {
            return Err(RiskscoreStatus::InvalidInput);
        }
        let st = ctx
            .tracks
            .update(track_id, now_us, risk)
            .map_err(warning_error)?;
        let result = RiskscoreTrackStatus {
            warning: u8::from(st.warning),
            event: event_code(st.event),
            new_track: u8::from(st.new_track),
            evicted_id: st.evicted.unwrap_or(RISKSCORE_NONE_U32),
        };
        // SAFETY: caller contract above; `out` is optional.
        unsafe { write_optional(out, result) };
        Ok(())
    };
    status(run())
}

/// Reads the state of track `track_id` as of `now_us` (staleness is judged at `now_us`: not updated
/// for more than `stale_after_us`, or last updated more than that after `now_us`, a reset time
/// base).
///
/// # Safety
/// `context` must be NULL or initialised; `out` NULL or writable.
#[no_mangle]
pub unsafe extern "C" fn riskscore_track_get(
    context: *const RiskscoreContext,
    track_id: u32,
    now_us: u64,
    out: *mut RiskscoreTrack,
) -> RiskscoreStatus {
    let run = || {
        // SAFETY: caller contract above.
        let ctx = unsafe { context_ref(context) }?;
        if out.is_null() {
            return Err(RiskscoreStatus::NullPointer);
        }
        let t = ctx
            .tracks
            .get(track_id)
            .ok_or(RiskscoreStatus::UnknownTrack)?;
        let stale = t.is_stale(now_us, ctx.tracks.config().stale_after_us);
        let result = RiskscoreTrack {
            id: t.id,
            warning: u8::from(ctx.tracks.is_warning(track_id, now_us)),
            stale: u8::from(stale),
            last_score: t.last_score,
            created_us: t.created_us,
            last_update_us: t.last_update_us,
            on_since_us: opt_us(t.on_since_us()),
            first_warning_us: opt_us(t.first_warning_us()),
            updates: t.updates,
            onsets: t.onsets,
        };
        // SAFETY: non-null (checked), writable per the caller contract.
        unsafe { write(out, result) }
    };
    status(run())
}

/// Drops the track of `track_id` (`RISKSCORE_STATUS_UNKNOWN_TRACK` if there is none).
///
/// # Safety
/// `context` must be NULL or initialised.
#[no_mangle]
pub unsafe extern "C" fn riskscore_track_remove(
    context: *mut RiskscoreContext,
    track_id: u32,
) -> RiskscoreStatus {
    // SAFETY: caller contract above.
    let run = || match unsafe { context_mut(context) }?.tracks.remove(track_id) {
        true => Ok(()),
        false => Err(RiskscoreStatus::UnknownTrack),
    };
    status(run())
}

/// Writes to `warning_count` the number of fresh (non-stale at `now_us`, as `riskscore_track_get`
/// judges it) tracks whose warning is on, and to `track_count` the number of tracks held (stale
/// ones included: those not updated for too long until the next update, those left ahead of
/// `now_us` by a reset time base until their own id's update, a remove or, not warning, an
/// eviction). Either output may be NULL.
///
/// # Safety
/// `context` must be NULL or initialised; the outputs NULL or writable.
#[no_mangle]
pub unsafe extern "C" fn riskscore_any_warning(
    context: *const RiskscoreContext,
    now_us: u64,
    warning_count: *mut u32,
    track_count: *mut u32,
) -> RiskscoreStatus {
    let run = || {
        // SAFETY: caller contract above.
        let ctx = unsafe { context_ref(context) }?;
        let warnings = sat_u32(ctx.tracks.warnings(now_us).count());
        let held = sat_u32(ctx.tracks.len());
        // SAFETY: caller contract above; both optional.
        unsafe {
            write_optional(warning_count, warnings);
            write_optional(track_count, held);
        }
        Ok(())
    };
    status(run())
}
