//! Stack high-water mark by painting: fill the unused stack below the current stack pointer with a
//! pattern, run the workload, then find the lowest word that no longer holds the pattern.
use core::ptr::{addr_of, read_volatile, write_volatile};

const PAINT: u32 = 0xCAFE_F00D;
/// How far below the stack pointer at painting time we paint (far beyond any plausible use; the
/// report says so if the workload reached the bottom).
pub const PAINT_BYTES: usize = 32 * 1024;

extern "C" {
    /// Initial stack pointer (top of RAM), from cortex-m-rt's link.x.
    static _stack_start: u32;
    /// End of .data/.bss, where the stack may grow down to.
    static __sheap: u32;
}

/// Painted region: `[bottom, top)` in bytes, word aligned.
pub struct Painted {
    bottom: usize,
    top: usize,
}

/// Result of [`Painted::measure`].
pub struct HighWater {
    /// Bytes of stack used from the reset stack pointer down to the lowest touched word.
    pub total: usize,
    /// True when the lowest painted word was overwritten (the real use may be larger).
    pub reached_bottom: bool,
}

/// Paints from just below the current stack pointer down `PAINT_BYTES` bytes (or to the end of
/// static RAM, whichever is higher).
#[inline(never)]
pub fn paint() -> Painted {
    paint_bytes(PAINT_BYTES)
}

/// Stack bytes used by `f` below the caller's stack pointer (painting granularity: the ~100 bytes
/// of `paint_bytes`' own frame are not painted, so tiny uses read as that gap).
#[inline(never)]
pub fn depth_of<R>(f: impl FnOnce() -> R) -> (R, usize) {
    let sp = cortex_m::register::msp::read() as usize;
    let painted = paint_bytes(8 * 1024);
    let r = core::hint::black_box(f());
    (r, sp.saturating_sub(painted.lowest_touched()))
}

#[inline(never)]
fn paint_bytes(bytes: usize) -> Painted {
    let sp = cortex_m::register::msp::read() as usize;
    // Leave a margin for this function's own frame.
    let top = (sp - 64) & !3;
    let limit = addr_of!(__sheap) as usize;
    let bottom = top.saturating_sub(bytes).max(limit);
    let mut p = bottom;
    while p < top {
        // SAFETY: [bottom, top) lies between the end of static data and below the live stack
        // frames (64 bytes under the current SP), so nothing live is overwritten; word aligned.
        unsafe { write_volatile(p as *mut u32, PAINT) };
        p += 4;
    }
    Painted { bottom, top }
}

impl Painted {
    /// Lowest address whose word no longer holds the pattern (`top` if none was touched).
    pub fn lowest_touched(&self) -> usize {
        let mut p = self.bottom;
        // SAFETY: reads within the region painted by `paint`, word aligned.
        while p < self.top && unsafe { read_volatile(p as *const u32) } == PAINT {
            p += 4;
        }
        p
    }

    pub fn measure(&self) -> HighWater {
        let mut p = self.bottom;
        // SAFETY: reads within the region painted above, word aligned.
        while p < self.top && unsafe { read_volatile(p as *const u32) } == PAINT {
            p += 4;
        }
        let stack_top = addr_of!(_stack_start) as usize;
        HighWater {
            total: stack_top - p,
            reached_bottom: p == self.bottom,
        }
    }
}
