//! riskscore on a Cortex-M4F (QEMU `mps2-an386`): decodes the embedded model blobs, runs every
//! embedded golden input through the whole pipeline twice (stage by stage through `scorer-core`,
//! and through the C ABI of `scorer-ffi`), and reports every number over semihosting as exact
//! IEEE-754 bits. `tests/tests/firmware_parity.rs` recomputes everything on the host and compares.
//!
//! No heap: there is no `#[global_allocator]` and no `alloc` crate in the link, so any allocation
//! would fail to link. The panic handler (in `scorer-ffi`) calls [`riskscore_panic`], which exits
//! with [`host::EXIT_PANIC`]; the host test checks that code never appears.
//!
//! Command line (QEMU `-append`): `limit=N` scores only the first N inputs, `nodump` omits the model
//! hex dump, `stack` adds a per-stage stack measurement (all used by `tests/firmware/measure`).
//!
//! Output lines (space separated; `<x>` = 8 hex digits of an `f32`'s bits):
//! - `FIRMWARE riskscore 1`
//! - `MODEL <slot> <kind> <bytes> <payload-crc hex> <source...>` and `BLOB <slot> <offset> <hex>`
//! - `SIZES context_used=.. context_reserved=.. track=.. table_base=.. max_tracks=.. macs=..
//!   inputs=.. drl_blob=.. msra_blob=..` and, with `stack`, `STAGESTACK <stage>=<bytes> ...`
//! - `CONFIG <threshold x> <hysteresis x> <min_on_us> <stale_after_us>` (live mode, evict when full)
//! - per input: `R <csv line> I <18 x> F <13 x> S <5 x> X <13 x> D <x> M <x> W <id> <now_us> <warning>
//!   <event> <new> <evicted|-> C <c-api-agrees 0/1> P <pipeline-agrees 0/1>`
//! - `STACK total=.. pipeline=.. painted_bottom_reached=0/1`, `DONE <n>`, then exit code 0.
#![no_std]
#![no_main]

mod host;
mod probe;
mod stack;

use core::hint::black_box;
use core::mem::size_of;
use core::ptr::addr_of_mut;

use cortex_m_rt::{entry, exception, ExceptionFrame};
use scorer_core::geometry_cell::geometry_cell;
use scorer_core::model::{self, Model, ModelBlob, OutsidePolicy};
use scorer_core::warning::{Track, TrackTable, WarningConfig, WarningEvent};
use scorer_core::{
    box_distance, drl_inputs, ei, features, tadv, tadv_corridor, ttc2d, DrlInputs, Observation,
    Surrogates, VehicleState,
};
use scorer_ffi::{
    RiskscoreContext, RiskscorePairResult, RiskscoreStatus, RiskscoreTrackStatus,
    RiskscoreVehicleState, RiskscoreWarningConfig, RISKSCORE_CONTEXT_SIZE, RISKSCORE_CONTEXT_WORDS,
    RISKSCORE_MAX_TRACKS, RISKSCORE_NONE_U32,
};

use host::Out;

static DRL_BLOB: &[u8] = include_bytes!(concat!(env!("OUT_DIR"), "/drl.rsk"));
static MSRA_BLOB: &[u8] = include_bytes!(concat!(env!("OUT_DIR"), "/msra.rsk"));
static DRL_SOURCE: &str = include_str!(concat!(env!("OUT_DIR"), "/drl.source"));
static MSRA_SOURCE: &str = include_str!(concat!(env!("OUT_DIR"), "/msra.source"));
/// `u32 count`, then `count` records of `u32 csv_line` + 18 `f32` (see build.rs).
static INPUTS: &[u8] = include_bytes!(concat!(env!("OUT_DIR"), "/inputs.bin"));
const RECORD_BYTES: usize = 4 + 18 * 4;

/// The C API context, statically allocated as a C firmware would.
static mut CONTEXT: RiskscoreContext = RiskscoreContext {
    opaque: [0; RISKSCORE_CONTEXT_WORDS],
};

/// Scores that set the warning threshold (their median).
const THRESHOLD_SAMPLE: usize = 31;
/// Time between two inputs (each input is one partner update).
const FRAME_US: u64 = 50_000;
const STALE_AFTER_US: u64 = 1_000_000;
const MIN_ON_US: u64 = 100_000;

/// Called by the panic handler of `scorer-ffi`; never reached (the host test checks the exit code).
#[no_mangle]
pub extern "C" fn riskscore_panic() -> ! {
    host::exit(host::EXIT_PANIC)
}

#[exception]
unsafe fn HardFault(_frame: &ExceptionFrame) -> ! {
    host::exit(3)
}

#[entry]
fn main() -> ! {
    let painted = stack::paint();
    let mut out = Out::open();
    let mut cmd = [0u8; 128];
    let cmdline = host::cmdline(&mut cmd);
    let limit = option_value(cmdline, b"limit=").unwrap_or(u32::MAX) as usize;
    let dump = !words(cmdline).any(|w| w == b"nodump");

    out.str("FIRMWARE riskscore 1").end();
    let drl = load(&mut out, "drl", DRL_BLOB, DRL_SOURCE, dump);
    let msra = load(&mut out, "msra", MSRA_BLOB, MSRA_SOURCE, dump);
    let drl_guarded = match model::decode_blob(DRL_BLOB) {
        Ok(b) if b.meta.training_domain.is_some() => b,
        _ => fail(&mut out, "the DRL blob carries no training domain"),
    };
    // What the C ABI's MSRA slot scores: the blob with its records (the host checks the flag too).
    let msra_guarded = match model::decode_blob(MSRA_BLOB) {
        Ok(b) => b,
        Err(_) => fail(&mut out, "the MSRA blob does not decode"),
    };

    out.str("SIZES context_used=")
        .u32(scorer_ffi::context_bytes_used() as u32)
        .str(" context_reserved=")
        .u32(RISKSCORE_CONTEXT_SIZE as u32)
        .str(" track=")
        .u32(size_of::<Track>() as u32)
        .str(" table_base=")
        .u32(size_of::<TrackTable<0>>() as u32)
        .str(" max_tracks=")
        .u32(RISKSCORE_MAX_TRACKS as u32)
        .str(" macs=")
        .u32(mac_count(&drl))
        .str(" inputs=")
        .u32(INPUTS.len() as u32)
        .str(" drl_blob=")
        .u32(DRL_BLOB.len() as u32)
        .str(" msra_blob=")
        .u32(MSRA_BLOB.len() as u32)
        .end();
    if words(cmdline).any(|w| w == b"stack") {
        stage_stacks(&mut out, &drl, &msra, record_count().min(limit));
    }

    let count = record_count().min(limit);
    let threshold = median_score(&drl, count.min(THRESHOLD_SAMPLE));
    let hysteresis = 0.1
        * if threshold < 0.0 {
            -threshold
        } else {
            threshold
        };
    let config = WarningConfig::live(threshold, hysteresis, MIN_ON_US, STALE_AFTER_US);
    out.str("CONFIG ")
        .f32(threshold)
        .str(" ")
        .f32(hysteresis)
        .str(" ")
        .u32(MIN_ON_US as u32)
        .str(" ")
        .u32(STALE_AFTER_US as u32)
        .end();
    // `staged` takes the unguarded staged score, `pipeline` the deployed path's guarded one,
    // `staged_guarded` the staged guarded score: the last two must agree update for update.
    let (mut staged, mut pipeline, mut staged_guarded_table) = match (
        TrackTable::<RISKSCORE_MAX_TRACKS>::new(config),
        TrackTable::<RISKSCORE_MAX_TRACKS>::new(config),
        TrackTable::<RISKSCORE_MAX_TRACKS>::new(config),
    ) {
        (Ok(a), Ok(b), Ok(c)) => (a, b, c),
        _ => fail(&mut out, "warning config rejected"),
    };
    let context = c_api_init(&mut out, &config);

    let sp_before = cortex_m::register::msp::read() as usize;
    // True while every update so far was inside the domain (the two tables still agree).
    let mut pipeline_inside = true;
    for k in 0..count {
        let Some((line, ego, partner)) = record(k) else {
            fail(&mut out, "inputs.bin truncated");
        };
        let (id, now) = track_of(k);

        // Stage by stage, through scorer-core. black_box pins each stage between its probes.
        probe::probe_features();
        let f = black_box(features(black_box(&ego), black_box(&partner)));
        probe::probe_box_distance();
        let bd = black_box(box_distance(black_box(&ego), black_box(&partner)));
        probe::probe_ttc2d();
        let t2 = black_box(ttc2d(black_box(&ego), black_box(&partner)));
        probe::probe_tadv();
        let ta = black_box(tadv(black_box(&ego), black_box(&partner)));
        probe::probe_tadv_corridor();
        let tc = black_box(tadv_corridor(black_box(&ego), black_box(&partner)));
        probe::probe_ei();
        let e = black_box(ei(black_box(&ego), black_box(&partner)));
        let s = Surrogates {
            box_distance: bd,
            ttc2d: t2,
            tadv: ta,
            tadv_corridor: tc,
            ei: e,
        };
        probe::probe_drl_inputs();
        let x = black_box(drl_inputs(black_box(&ego), black_box(&partner)));
        let o = Observation {
            features: f,
            surrogates: s,
            drl_inputs: x,
        };
        probe::probe_guard();
        let (first_outside, clamped) = black_box(guard_inputs(&drl_guarded, black_box(&x)));
        probe::probe_int8_mlp();
        let d = black_box(drl.score_observation(black_box(&o)));
        probe::probe_msra();
        let m = black_box(msra.score_observation(black_box(&o)));
        probe::probe_warning_update();
        let status = black_box(staged.update(id, now, d));

        // The deployed per-partner DRL path: raw states -> guarded score -> warning.
        probe::probe_drl_pipeline();
        let g = black_box(drl_guarded.score_pair_guarded(black_box(&ego), black_box(&partner)));
        let pipeline_status = black_box(pipeline.update(id, now, g.score));

        // The same through the C ABI.
        probe::probe_c_api();
        let c = c_api_step(context, &ego, &partner, id, now);
        probe::probe_idle();

        // The staged guarded score: the int8 network on the guard's inputs, or the fallback.
        let staged_guarded = staged_guarded_score(
            &drl_guarded,
            &drl,
            first_outside,
            &Observation {
                drl_inputs: clamped,
                ..o
            },
        );
        // Inside the domain the deployed path is the unguarded one (same score, same table, as
        // long as no earlier update was guarded), unless the blob blends the fallback in there;
        // everywhere it is the staged guarded score.
        let inside_so_far =
            pipeline_inside && first_outside.is_none() && drl_guarded.meta.blend.is_none();
        pipeline_inside = inside_so_far;
        let staged_guarded_status = staged_guarded_table.update(id, now, staged_guarded);
        let pipeline_ok = g.score.to_bits() == staged_guarded.to_bits()
            && pipeline_status == staged_guarded_status
            && g.first_outside == first_outside
            && g.in_domain == first_outside.is_none()
            && pipeline_status.is_ok()
            && (!inside_so_far || (g.score.to_bits() == d.to_bits() && pipeline_status == status));
        // The C ABI scores through each blob's guard: the deployed path's DRL score and table.
        let msra_g = msra_guarded.score_guarded(&o);
        let c_ok = match (&c, &pipeline_status) {
            (Some((pr, ts)), Ok(st)) => {
                same_bits(&pr.features, &f)
                    && same_bits(
                        &[pr.box_distance, pr.ttc2d, pr.tadv, pr.ei],
                        &[bd, t2, ta, e],
                    )
                    && pr.drl_score.to_bits() == g.score.to_bits()
                    && (pr.drl_in_domain != 0) == g.in_domain
                    && pr.msra_score.to_bits() == msra_g.score.to_bits()
                    && (pr.msra_in_domain != 0) == msra_g.in_domain
                    && pr.gssm_in_domain == 1
                    && (ts.warning != 0) == st.warning
                    && ts.event as u8 == event_code(st.event)
                    && (ts.new_track != 0) == st.new_track
                    && ts.evicted_id == st.evicted.unwrap_or(RISKSCORE_NONE_U32)
            }
            _ => false,
        };

        out.str("R ").u32(line).str(" I");
        for v in state_fields(&ego)
            .iter()
            .chain(state_fields(&partner).iter())
        {
            out.str(" ").f32(*v);
        }
        out.str(" F");
        for v in f {
            out.str(" ").f32(v);
        }
        out.str(" S");
        for v in [bd, t2, ta, e, tc] {
            out.str(" ").f32(v);
        }
        out.str(" X");
        for v in x {
            out.str(" ").f32(v);
        }
        out.str(" D ").f32(d).str(" M ").f32(m);
        out.str(" W ").u32(id).str(" ").u32(now as u32).str(" ");
        match status {
            Ok(st) => {
                out.u32(u32::from(st.warning))
                    .str(" ")
                    .u32(u32::from(event_code(st.event)))
                    .str(" ")
                    .u32(u32::from(st.new_track))
                    .str(" ");
                match st.evicted {
                    Some(v) => out.u32(v),
                    None => out.str("-"),
                };
            }
            Err(_) => {
                out.str("error - - -");
            }
        }
        out.str(" G ")
            .f32(g.score)
            .str(" ")
            .u32(u32::from(g.in_domain))
            .str(" ");
        match g.first_outside {
            Some(i) => out.u32(u32::from(i)),
            None => out.str("-"),
        };
        out.str(" C ")
            .u32(u32::from(c_ok))
            .str(" P ")
            .u32(u32::from(pipeline_ok))
            .end();
    }

    let hw = painted.measure();
    let stack_top = stack_top();
    out.str("STACK total=")
        .u32(hw.total as u32)
        .str(" pipeline=")
        .u32(hw.total.saturating_sub(stack_top - sp_before) as u32)
        .str(" painted_bottom_reached=")
        .u32(u32::from(hw.reached_bottom))
        .end();
    out.str("DONE ").u32(count as u32).end();
    host::exit(0)
}

/// Worst stack depth of each stage over the first `n` inputs (`STAGESTACK` line, bytes).
fn stage_stacks(out: &mut Out, drl: &Model<'_>, msra: &Model<'_>, n: usize) {
    let mut worst = [0usize; 11];
    let mut table =
        match TrackTable::<RISKSCORE_MAX_TRACKS>::new(WarningConfig::live(0.0, 0.0, 0, 1)) {
            Ok(t) => t,
            Err(_) => fail(out, "stack config rejected"),
        };
    for k in 0..n {
        let Some((_, ego, p)) = record(k) else { break };
        let (f, d0) = stack::depth_of(|| features(&ego, &p));
        let (bd, d1) = stack::depth_of(|| box_distance(&ego, &p));
        let (t2, d2) = stack::depth_of(|| ttc2d(&ego, &p));
        let (ta, d3) = stack::depth_of(|| tadv(&ego, &p));
        let (e, d4) = stack::depth_of(|| ei(&ego, &p));
        let (tc, d10) = stack::depth_of(|| tadv_corridor(&ego, &p));
        let s = Surrogates {
            box_distance: bd,
            ttc2d: t2,
            tadv: ta,
            tadv_corridor: tc,
            ei: e,
        };
        let (x, d9) = stack::depth_of(|| drl_inputs(&ego, &p));
        let o = Observation {
            features: f,
            surrogates: s,
            drl_inputs: x,
        };
        let (d, d5) = stack::depth_of(|| drl.score_observation(&o));
        let (_, d6) = stack::depth_of(|| msra.score_observation(&o));
        let (_, d7) = stack::depth_of(|| table.update(1, k as u64, d));
        let (_, d8) = stack::depth_of(|| drl.score(&ego, &p));
        for (w, d) in worst
            .iter_mut()
            .zip([d0, d1, d2, d3, d4, d5, d6, d7, d8, d9, d10])
        {
            *w = (*w).max(d);
        }
    }
    out.str("STAGESTACK");
    let names = [
        "features",
        "box_distance",
        "ttc2d",
        "tadv",
        "ei",
        "int8_mlp",
        "msra",
        "warning_update",
        "drl_score",
        "drl_inputs",
        "tadv_corridor",
    ];
    for (name, w) in names.iter().zip(worst) {
        out.str(" ").str(name).str("=").u32(w as u32);
    }
    out.end();
}

fn fail(out: &mut Out, why: &str) -> ! {
    out.str("ERROR ").str(why).end();
    host::exit(host::EXIT_FAILURE)
}

/// Decodes one embedded blob (exits on error) and reports it.
fn load(
    out: &mut Out,
    slot: &str,
    blob: &'static [u8],
    source: &str,
    dump: bool,
) -> Model<'static> {
    let m = match model::decode(blob) {
        Ok(m) => m,
        Err(_) => {
            out.str("ERROR model ")
                .str(slot)
                .str(": decode failed")
                .end();
            host::exit(host::EXIT_FAILURE)
        }
    };
    let crc = model::decode_header(blob).map_or(0, |h| h.payload_crc);
    out.str("MODEL ")
        .str(slot)
        .str(" ")
        .str(m.kind().name())
        .str(" ")
        .u32(blob.len() as u32)
        .str(" ")
        .hex32(crc)
        .str(" ")
        .str(source.trim())
        .end();
    if dump {
        for (i, chunk) in blob.chunks(256).enumerate() {
            out.str("BLOB ")
                .str(slot)
                .str(" ")
                .u32((i * 256) as u32)
                .str(" ")
                .hex_bytes(chunk)
                .end();
        }
    }
    m
}

/// Multiply-accumulates of one int8 forward pass (0 for other model kinds).
fn mac_count(m: &Model<'_>) -> u32 {
    let Model::DrlInt8(q) = m else { return 0 };
    let mut in_dim = q.inputs.len() as u32;
    let mut macs = 0;
    for layer in q.layers.iter() {
        macs += in_dim * u32::from(layer.out_dim);
        in_dim = u32::from(layer.out_dim);
    }
    macs
}

fn record_count() -> usize {
    INPUTS
        .get(..4)
        .and_then(|b| b.try_into().ok())
        .map_or(0, |b| u32::from_le_bytes(b) as usize)
}

fn record(k: usize) -> Option<(u32, VehicleState, VehicleState)> {
    let start = 4 + k * RECORD_BYTES;
    let bytes = INPUTS.get(start..start + RECORD_BYTES)?;
    let word = |i: usize| -> Option<[u8; 4]> { bytes.get(4 * i..4 * i + 4)?.try_into().ok() };
    let line = u32::from_le_bytes(word(0)?);
    let mut v = [0f32; 18];
    for (i, slot) in v.iter_mut().enumerate() {
        *slot = f32::from_le_bytes(word(1 + i)?);
    }
    let state = |o: usize| -> Option<VehicleState> {
        let g = |i: usize| v.get(o + i).copied();
        Some(VehicleState {
            x: g(0)?,
            y: g(1)?,
            vx: g(2)?,
            vy: g(3)?,
            hx: g(4)?,
            hy: g(5)?,
            acc: g(6)?,
            length: g(7)?,
            width: g(8)?,
        })
    };
    Some((line, state(0)?, state(9)?))
}

/// Partner id and time of input `k`: seven partners in turn every 50 ms; during every third block
/// of 40 inputs only five are updated, so partners 6 and 7 go stale (> 1 s) and are re-created.
fn track_of(k: usize) -> (u32, u64) {
    let partners = if (k / 40) % 3 == 2 { 5 } else { 7 };
    ((k % partners) as u32 + 1, k as u64 * FRAME_US)
}

fn state_fields(s: &VehicleState) -> [f32; 9] {
    [s.x, s.y, s.vx, s.vy, s.hx, s.hy, s.acc, s.length, s.width]
}

fn same_bits(a: &[f32], b: &[f32]) -> bool {
    a.len() == b.len() && a.iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits())
}

fn event_code(e: WarningEvent) -> u8 {
    match e {
        WarningEvent::None => 0,
        WarningEvent::Onset => 1,
        WarningEvent::Release => 2,
    }
}

/// The guard's own work on the DRL inputs: the first input outside its trained range and the
/// inputs the blob's policy scores (clamped under `Clamp`).
fn guard_inputs(blob: &ModelBlob<'_>, x: &DrlInputs) -> (Option<u8>, DrlInputs) {
    let mut inputs = *x;
    let Some(domain) = &blob.meta.training_domain else {
        return (None, inputs);
    };
    let first = domain.first_outside(x, || geometry_cell(x));
    if first.is_some() && domain.policy == OutsidePolicy::Clamp {
        domain.clamp(&mut inputs);
    }
    (first, inputs)
}

/// The score of the staged stages under the blob's policy: the kinematic fallback of the staged
/// surrogates outside under `Fallback` and `Blend`, the int8 network on the guard's inputs inside
/// (under `Blend` mixed with that fallback) and under the other policies.
fn staged_guarded_score(
    blob: &ModelBlob<'_>,
    drl: &Model<'_>,
    first_outside: Option<u8>,
    guarded: &Observation,
) -> f32 {
    let policy = blob.meta.training_domain.map(|d| d.policy);
    let uses_fallback = policy.is_some_and(OutsidePolicy::uses_fallback);
    match (&blob.meta.kinematic_fallback, &blob.meta.blend) {
        (Some(fallback), _) if uses_fallback && first_outside.is_some() => {
            fallback.score(&guarded.surrogates)
        }
        (Some(fallback), Some(blend)) if policy == Some(OutsidePolicy::Blend) => blend.mix(
            drl.score_observation(guarded),
            fallback.score(&guarded.surrogates),
        ),
        _ => drl.score_observation(guarded),
    }
}

/// Median DRL score of the first `n` inputs: a warning threshold inside the score range, so the
/// run contains onsets and releases whatever model is embedded.
fn median_score(drl: &Model<'_>, n: usize) -> f32 {
    let mut scores = [0f32; THRESHOLD_SAMPLE];
    let mut len = 0;
    for (k, slot) in scores.iter_mut().enumerate().take(n) {
        if let Some((_, ego, partner)) = record(k) {
            *slot = drl.score(&ego, &partner);
            len += 1;
        }
    }
    // Selection by counting (no sort: keeps library code with panic paths out of the image).
    let sample = scores.get(..len).unwrap_or(&[]);
    for &candidate in sample {
        let below = sample.iter().filter(|&&x| x < candidate).count();
        let equal = sample.iter().filter(|&&x| x == candidate).count();
        if below <= len / 2 && len / 2 < below + equal {
            return candidate;
        }
    }
    0.0
}

fn stack_top() -> usize {
    extern "C" {
        static _stack_start: u32;
    }
    // Only the address of the linker symbol is taken (no read).
    core::ptr::addr_of!(_stack_start) as usize
}

/// The words of the command line, separated by spaces (hand-rolled: `str::split` links a slice
/// bounds check, i.e. a panic path, which this firmware proves absent).
fn words(cmdline: &[u8]) -> impl Iterator<Item = &[u8]> {
    let mut rest = cmdline;
    core::iter::from_fn(move || loop {
        let len = rest.iter().position(|&b| b == b' ').unwrap_or(rest.len());
        let (word, tail) = rest.split_at_checked(len)?;
        rest = tail.get(1..).unwrap_or(&[]);
        if !word.is_empty() {
            return Some(word);
        }
        if rest.is_empty() {
            return None;
        }
    })
}

/// The decimal value of the word `key=N`, if present.
fn option_value(cmdline: &[u8], key: &[u8]) -> Option<u32> {
    let digits = words(cmdline).find_map(|w| w.strip_prefix(key))?;
    let mut v: u32 = 0;
    for &d in digits {
        if !d.is_ascii_digit() {
            return None;
        }
        v = v.checked_mul(10)?.checked_add(u32::from(d - b'0'))?;
    }
    Some(v)
}

// ------------------------------------------------------------------------------------------------
// The C ABI path (the functions a C firmware calls, called here from Rust).

fn c_api_init(out: &mut Out, config: &WarningConfig) -> *mut RiskscoreContext {
    let ctx = addr_of_mut!(CONTEXT);
    let c = RiskscoreWarningConfig {
        threshold: config.threshold,
        hysteresis: config.hysteresis,
        min_on_us: config.min_on_us,
        stale_after_us: config.stale_after_us,
        latch: u8::from(config.latch),
        evict_when_full: 1,
    };
    // SAFETY: `ctx` points to the static context (RISKSCORE_CONTEXT_SIZE bytes, aligned), used only
    // from this single thread; the blobs are 'static.
    let ok = unsafe {
        scorer_ffi::riskscore_init(ctx, RISKSCORE_CONTEXT_SIZE, &c) == RiskscoreStatus::Ok
            && scorer_ffi::riskscore_load_model(
                ctx,
                DRL_BLOB.as_ptr(),
                DRL_BLOB.len(),
                core::ptr::null_mut(),
            ) == RiskscoreStatus::Ok
            && scorer_ffi::riskscore_load_model(
                ctx,
                MSRA_BLOB.as_ptr(),
                MSRA_BLOB.len(),
                core::ptr::null_mut(),
            ) == RiskscoreStatus::Ok
    };
    if !ok {
        fail(out, "C API initialisation failed");
    }
    ctx
}

fn c_api_step(
    ctx: *mut RiskscoreContext,
    ego: &VehicleState,
    partner: &VehicleState,
    id: u32,
    now: u64,
) -> Option<(RiskscorePairResult, RiskscoreTrackStatus)> {
    let c_state = |s: &VehicleState| RiskscoreVehicleState {
        x: s.x,
        y: s.y,
        vx: s.vx,
        vy: s.vy,
        hx: s.hx,
        hy: s.hy,
        acc: s.acc,
        length: s.length,
        width: s.width,
    };
    let (e, p) = (c_state(ego), c_state(partner));
    let mut result = core::mem::MaybeUninit::<RiskscorePairResult>::uninit();
    let mut status = core::mem::MaybeUninit::<RiskscoreTrackStatus>::uninit();
    // SAFETY: `ctx` is the initialised static context; the other pointers are live locals; the
    // outputs are read only after the calls reported success (they are fully written then).
    unsafe {
        if scorer_ffi::riskscore_score_pair(ctx, &e, &p, result.as_mut_ptr()) != RiskscoreStatus::Ok
        {
            return None;
        }
        let result = result.assume_init();
        if scorer_ffi::riskscore_track_update(ctx, id, now, result.drl_score, status.as_mut_ptr())
            != RiskscoreStatus::Ok
        {
            return None;
        }
        Some((result, status.assume_init()))
    }
}
