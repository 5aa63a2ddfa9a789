//! Footprint probe: what a C ECU integration of the DRL model costs. Links the whole C ABI
//! (`scorer-ffi`: every model kind, every surrogate, the track table) plus the embedded DRL blob,
//! scores one partner through `riskscore_score_pair` + `riskscore_track_update`, and reports its
//! stack high-water mark. tests/firmware/measure reads its section sizes as the flash/RAM budget.
#![no_std]
#![no_main]

#[path = "../footprint_report.rs"]
mod footprint_report;
#[path = "../stack.rs"]
#[allow(dead_code)]
mod stack;

use core::ptr::{addr_of, addr_of_mut, read_volatile};

use cortex_m_rt::entry;
use cortex_m_semihosting::debug;
use scorer_ffi::{
    RiskscoreContext, RiskscorePairResult, RiskscoreStatus, RiskscoreVehicleState,
    RiskscoreWarningConfig, RISKSCORE_CONTEXT_SIZE, RISKSCORE_CONTEXT_WORDS,
};

static DRL_BLOB: &[u8] = include_bytes!(concat!(env!("OUT_DIR"), "/drl.rsk"));
static mut CONTEXT: RiskscoreContext = RiskscoreContext {
    opaque: [0; RISKSCORE_CONTEXT_WORDS],
};
/// Read through volatile loads so the optimiser cannot constant-fold the pipeline.
static EGO: RiskscoreVehicleState = RiskscoreVehicleState {
    x: 0.0,
    y: 0.0,
    vx: 0.0,
    vy: 20.0,
    hx: 0.0,
    hy: 1.0,
    acc: 0.0,
    length: 4.5,
    width: 1.8,
};
static PARTNER: RiskscoreVehicleState = RiskscoreVehicleState {
    x: 1.0,
    y: 30.0,
    vx: 0.0,
    vy: 10.0,
    hx: 0.0,
    hy: 1.0,
    acc: -1.0,
    length: 4.8,
    width: 1.9,
};

#[no_mangle]
pub extern "C" fn riskscore_panic() -> ! {
    debug::exit(debug::EXIT_FAILURE);
    loop {
        cortex_m::asm::wfi();
    }
}

#[entry]
fn main() -> ! {
    let painted = stack::paint();
    let ctx = addr_of_mut!(CONTEXT);
    let cfg = RiskscoreWarningConfig {
        threshold: 0.5,
        hysteresis: 0.05,
        min_on_us: 500_000,
        stale_after_us: 1_000_000,
        latch: 0,
        evict_when_full: 1,
    };
    let mut result = core::mem::MaybeUninit::<RiskscorePairResult>::uninit();
    // SAFETY: single-threaded; `ctx` is the static context; the blob is 'static; the result is
    // read only after a successful call.
    let ok = unsafe {
        let ego = read_volatile(addr_of!(EGO));
        let partner = read_volatile(addr_of!(PARTNER));
        scorer_ffi::riskscore_init(ctx, RISKSCORE_CONTEXT_SIZE, &cfg) == RiskscoreStatus::Ok
            && scorer_ffi::riskscore_load_model(
                ctx,
                DRL_BLOB.as_ptr(),
                DRL_BLOB.len(),
                core::ptr::null_mut(),
            ) == RiskscoreStatus::Ok
            && scorer_ffi::riskscore_score_pair(ctx, &ego, &partner, result.as_mut_ptr())
                == RiskscoreStatus::Ok
            && scorer_ffi::riskscore_track_update(
                ctx,
                7,
                1_000,
                result.assume_init().drl_score,
                core::ptr::null_mut(),
            ) == RiskscoreStatus::Ok
    };
    let hw = painted.measure();
    footprint_report::report("c_api", ok, hw.total);
    debug::exit(if ok {
        debug::EXIT_SUCCESS
    } else {
        debug::EXIT_FAILURE
    });
    loop {
        cortex_m::asm::wfi();
    }
}
