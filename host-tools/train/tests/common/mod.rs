//! Synthetic training sequences shared by the comparison, training and GSSM tests.
#![allow(dead_code)] // each test crate uses some of these
use riskscore_data::events::{EventKind, Frame, Sequence};
use scorer_core::VehicleState;

/// A 4.5 m x 1.8 m car at `(x, y)` driving along +x at `v` m/s.
pub fn car(x: f32, y: f32, v: f32) -> VehicleState {
    VehicleState {
        x,
        y,
        vx: v,
        vy: 0.0,
        hx: 1.0,
        hy: 0.0,
        acc: 0.0,
        length: 4.5,
        width: 1.8,
    }
}

/// A rear-end approach at 10 Hz: the ego closes on a slower leader (offset `lateral` m sideways)
/// at `closing` m/s and touches it at `t_impact` = 6 s.
pub fn conflict(id: usize, closing: f32, lateral: f32) -> Sequence {
    let t_impact = 6.0f64;
    let v_ego = 14.0 + id as f32 % 5.0;
    let mut s = Sequence::new(format!("c{id}"), EventKind::Crash, Some(t_impact));
    for k in 15..=65 {
        let t = k as f64 * 0.1;
        let x_e = v_ego * t as f32;
        let gap = closing * (t_impact - t) as f32; // box distance along x
        s.frames.push(Frame {
            time: t,
            ego: car(x_e, 0.0, v_ego),
            partner: car(x_e + 4.5 + gap, lateral, v_ego - closing),
        });
    }
    s
}

/// Steady following at 10 Hz for 5 s: a leader `gap` m ahead (box to box), `lateral` m sideways,
/// both at `v` m/s.
pub fn following(id: usize, v: f32, gap: f32, lateral: f32) -> Sequence {
    let mut s = Sequence::new(format!("s{id}"), EventKind::Safe, None);
    for k in 0..50 {
        let t = k as f64 * 0.1;
        let x_e = v * t as f32;
        s.frames.push(Frame {
            time: t,
            ego: car(x_e, 0.0, v),
            partner: car(x_e + 4.5 + gap, lateral, v),
        });
    }
    s
}

/// `n` rear-end conflicts and `n` calm followings at town speeds (12-19 m/s), the small training
/// set of the fold tests.
pub fn in_town(n: usize) -> Vec<Sequence> {
    (0..n)
        .flat_map(|i| {
            [
                conflict(i, 5.0 + (i % 8) as f32, 0.0),
                following(i, 12.0 + i as f32 % 7.0, 25.0 + 3.0 * (i % 5) as f32, 0.0),
            ]
        })
        .collect()
}

/// The defaults scaled down for a test that trains: 1,000 comparisons, 6 epochs, a 13-8-8-1 DRL.
pub fn quick_config() -> riskscore_train::train::TrainConfig {
    let mut config = riskscore_train::train::TrainConfig::default();
    config.comparisons.temporal.pairs = 400;
    config.comparisons.cross_sequence.pairs = 400;
    config.comparisons.physics.pairs = 200;
    config.optimiser.max_epochs = 6;
    config.optimiser.batch_pairs = 256;
    config.drl.hidden = vec![8, 8];
    // The DRL falls back on the terms of the MSRA trained beside it (the default's separate
    // reference-TAdv MSRA is final_fallback.rs's subject).
    config.guard.fallback_surrogates = None;
    config
}
