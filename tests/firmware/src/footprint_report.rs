//! The one line a footprint probe prints, without `core::fmt`.

/// Prints `FOOTPRINT <probe> ok=<0|1> stack=<bytes>` to the semihosting console without
/// `core::fmt`: a footprint probe's flash is what an integration links, and no integration links
/// the formatting machinery (about 1.2 KB) that one `hprintln!` would add to the image.
pub fn report(probe: &str, ok: bool, stack: usize) {
    let mut digits = [0u8; 20];
    let mut n = stack;
    let mut start = digits.len();
    loop {
        start -= 1;
        digits[start] = b'0' + (n % 10) as u8;
        n /= 10;
        if n == 0 || start == 0 {
            break;
        }
    }
    if let Ok(mut out) = cortex_m_semihosting::hio::hstdout() {
        for part in [
            b"FOOTPRINT ".as_slice(),
            probe.as_bytes(),
            if ok { b" ok=1 stack=" } else { b" ok=0 stack=" },
            &digits[start..],
            b"\n",
        ] {
            let _ = out.write_all(part);
        }
    }
}
