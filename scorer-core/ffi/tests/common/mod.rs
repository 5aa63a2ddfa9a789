//! What the scorer-ffi tests share: a zeroed context, a warning configuration, the everyday
//! following pair and the C state as the core's `VehicleState`.
use scorer_ffi::{
    RiskscoreContext, RiskscoreVehicleState, RiskscoreWarningConfig, RISKSCORE_CONTEXT_WORDS,
};

pub fn config() -> RiskscoreWarningConfig {
    RiskscoreWarningConfig {
        threshold: 0.5,
        hysteresis: 0.05,
        min_on_us: 0,
        stale_after_us: 1_000_000,
        latch: 0,
        evict_when_full: 1,
    }
}

/// Zeroed context storage (not initialised).
pub fn context() -> Box<RiskscoreContext> {
    Box::new(RiskscoreContext {
        opaque: [0; RISKSCORE_CONTEXT_WORDS],
    })
}

pub const EGO: RiskscoreVehicleState = RiskscoreVehicleState {
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
/// 30 m ahead at 10 m/s: everyday following (inside the shipped DRL's domain).
pub const LEAD: RiskscoreVehicleState = RiskscoreVehicleState {
    y: 30.0,
    vy: 10.0,
    ..EGO
};

pub fn core_state(s: &RiskscoreVehicleState) -> scorer_core::VehicleState {
    scorer_core::VehicleState {
        x: s.x,
        y: s.y,
        vx: s.vx,
        vy: s.vy,
        hx: s.hx,
        hy: s.hy,
        acc: s.acc,
        length: s.length,
        width: s.width,
    }
}
