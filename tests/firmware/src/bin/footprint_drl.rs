//! Footprint probe: the smallest Rust integration of the deployed DRL path. Decodes the embedded
//! int8 DRL blob and runs DRL input encoding -> training-domain guard -> int8 network -> track
//! table for one partner, without the C ABI, the surrogates or the other model kinds' inference (model decoding still links the
//! deserialisers of every kind). tests/firmware/measure reads its section sizes.
#![no_std]
#![no_main]

#[path = "../footprint_report.rs"]
mod footprint_report;
#[path = "../stack.rs"]
#[allow(dead_code)]
mod stack;

use core::ptr::{addr_of, read_volatile};

use cortex_m_rt::entry;
use cortex_m_semihosting::debug;
use scorer_core::model;
use scorer_core::warning::{TrackTable, WarningConfig};
use scorer_core::VehicleState;

static DRL_BLOB: &[u8] = include_bytes!(concat!(env!("OUT_DIR"), "/drl.rsk"));
static EGO: VehicleState = VehicleState {
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
static PARTNER: VehicleState = VehicleState {
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
const TRACKS: usize = 32;

#[panic_handler]
fn panic(_: &core::panic::PanicInfo<'_>) -> ! {
    debug::exit(debug::EXIT_FAILURE);
    loop {
        cortex_m::asm::wfi();
    }
}

#[entry]
fn main() -> ! {
    let painted = stack::paint();
    // SAFETY: plain reads of immutable statics (volatile so the pipeline is not constant-folded).
    let (ego, partner) = unsafe {
        (
            read_volatile(addr_of!(EGO)),
            read_volatile(addr_of!(PARTNER)),
        )
    };
    // The guarded path: the blob's training domain is checked (and applied) on every partner.
    let score = match model::decode_blob(DRL_BLOB) {
        Ok(blob) if blob.meta.training_domain.is_some() => {
            Some(blob.score_pair_guarded(&ego, &partner).score)
        }
        _ => None,
    };
    let config = WarningConfig::live(0.5, 0.05, 500_000, 1_000_000);
    let ok = match (score, TrackTable::<TRACKS>::new(config)) {
        (Some(r), Ok(mut table)) => table.update(7, 1_000, r).is_ok(),
        _ => false,
    };
    let hw = painted.measure();
    footprint_report::report("drl", ok, hw.total);
    debug::exit(if ok {
        debug::EXIT_SUCCESS
    } else {
        debug::EXIT_FAILURE
    });
    loop {
        cortex_m::asm::wfi();
    }
}
