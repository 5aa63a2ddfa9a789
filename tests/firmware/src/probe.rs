//! Stage markers for instruction counting (tests/firmware/measure).
//!
//! Each probe is a tiny non-inlined function with a unique body (so the linker cannot fold two
//! into one address). The measure script traces every executed instruction under QEMU and
//! attributes the instructions executed between entering probe A and entering the next probe to
//! stage A (the probes' own instructions are excluded). Calling them costs a few instructions per
//! stage in the parity run; the host never sees them.
use core::ptr::addr_of_mut;
use core::ptr::write_volatile;

static mut LAST_STAGE: u32 = 0;

macro_rules! probes {
    ($($name:ident = $id:expr;)*) => {
        $(
            #[inline(never)]
            #[no_mangle]
            pub extern "C" fn $name() {
                // SAFETY: single-threaded firmware, no interrupts touch LAST_STAGE; the volatile
                // store keeps the probe (and its unique body) from being optimised away.
                unsafe { write_volatile(addr_of_mut!(LAST_STAGE), $id) };
            }
        )*
    };
}

probes! {
    probe_features = 1;
    probe_box_distance = 2;
    probe_ttc2d = 3;
    probe_tadv = 4;
    probe_ei = 5;
    probe_int8_mlp = 6;
    probe_msra = 7;
    probe_warning_update = 8;
    probe_drl_pipeline = 9;
    probe_c_api = 10;
    probe_idle = 11;
    probe_drl_inputs = 12;
    probe_guard = 13;
    probe_tadv_corridor = 14;
}
