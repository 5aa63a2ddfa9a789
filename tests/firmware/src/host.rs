//! Talking to the host over ARM semihosting: line output on the host's stdout, the command line
//! given to QEMU with `-append`, and the exit code (SYS_EXIT_EXTENDED, so QEMU exits with any code).
use cortex_m_semihosting::hio::{self, HostStream};

/// Exit code when the panic handler runs (the host test checks it is never seen).
pub const EXIT_PANIC: u32 = 101;
/// Exit code when the firmware detects a failure itself (message printed before).
pub const EXIT_FAILURE: u32 = 2;

/// Semihosting operation numbers (ARM semihosting specification 2.0).
const SYS_GET_CMDLINE: usize = 0x15;
const SYS_EXIT_EXTENDED: usize = 0x20;
/// `ADP_Stopped_ApplicationExit`: the reason code that makes the second word the exit status.
const ADP_STOPPED_APPLICATION_EXIT: usize = 0x20026;

/// Ends the QEMU run with `code` as its process exit status.
pub fn exit(code: u32) -> ! {
    let block = [ADP_STOPPED_APPLICATION_EXIT, code as usize];
    // SAFETY: SYS_EXIT_EXTENDED reads the two-word parameter block, which lives for the call.
    unsafe {
        cortex_m_semihosting::syscall(SYS_EXIT_EXTENDED, &block);
    }
    // Only reached without a debugger/QEMU attached: stop here.
    loop {
        cortex_m::asm::bkpt();
    }
}

/// Copies the command line (QEMU `-kernel ELF -append "..."`) into `buf`; returns its bytes, or an
/// empty slice when there is none or it does not fit.
pub fn cmdline(buf: &mut [u8]) -> &[u8] {
    let mut block = [buf.as_mut_ptr() as usize, buf.len()];
    // SAFETY: SYS_GET_CMDLINE writes at most block[1] bytes to block[0] (our buffer) and stores the
    // length written back into block[1]; both outlive the call.
    // `&mut`: the host writes through this pointer, so it must not be a shared borrow.
    #[allow(clippy::unnecessary_mut_passed)]
    let failed = unsafe { cortex_m_semihosting::syscall(SYS_GET_CMDLINE, &mut block) } != 0;
    if failed {
        return &[];
    }
    let len = block[1].min(buf.len());
    let text = buf.get(..len).unwrap_or(&[]);
    let end = text.iter().position(|&b| b == 0).unwrap_or(text.len());
    text.get(..end).unwrap_or(&[])
}

/// A line-buffered writer to the host's stdout (one semihosting write per line).
pub struct Out {
    stream: Option<HostStream>,
    line: [u8; 1024],
    len: usize,
    overflow: bool,
}

impl Out {
    pub fn open() -> Self {
        Out {
            stream: hio::hstdout().ok(),
            line: [0; 1024],
            len: 0,
            overflow: false,
        }
    }

    pub fn str(&mut self, s: &str) -> &mut Self {
        self.bytes(s.as_bytes())
    }

    fn bytes(&mut self, b: &[u8]) -> &mut Self {
        match self.line.get_mut(self.len..self.len + b.len()) {
            Some(dst) => {
                dst.copy_from_slice(b);
                self.len += b.len();
            }
            None => self.overflow = true,
        }
        self
    }

    /// Decimal unsigned integer.
    pub fn u32(&mut self, v: u32) -> &mut Self {
        let mut digits = [0u8; 10];
        let mut n = 0;
        let mut rest = v;
        for d in digits.iter_mut().rev() {
            *d = b'0' + (rest % 10) as u8;
            rest /= 10;
            n += 1;
            if rest == 0 {
                break;
            }
        }
        let start = digits.len() - n;
        self.bytes(digits.get(start..).unwrap_or(&[]))
    }

    /// Eight lower-case hex digits.
    pub fn hex32(&mut self, v: u32) -> &mut Self {
        let mut digits = [0u8; 8];
        for (k, d) in digits.iter_mut().enumerate() {
            *d = hex_digit((v >> (28 - 4 * k)) & 0xf);
        }
        self.bytes(&digits)
    }

    /// The IEEE-754 bits of `x` as eight hex digits (exact, unlike decimal).
    pub fn f32(&mut self, x: f32) -> &mut Self {
        self.hex32(x.to_bits())
    }

    /// Two hex digits per byte.
    pub fn hex_bytes(&mut self, bytes: &[u8]) -> &mut Self {
        for &b in bytes {
            let pair = [hex_digit(u32::from(b >> 4)), hex_digit(u32::from(b & 0xf))];
            self.bytes(&pair);
        }
        self
    }

    /// Sends the line (with a newline) and starts a new one. A line longer than the buffer is
    /// reported as an error line instead of being cut silently.
    pub fn end(&mut self) {
        if self.overflow {
            self.len = 0;
            self.overflow = false;
            self.str("error: output line too long for the firmware's line buffer");
        }
        self.bytes(b"\n");
        if let Some(stream) = self.stream.as_mut() {
            let _ = stream.write_all(self.line.get(..self.len).unwrap_or(&[]));
        }
        self.len = 0;
    }
}

fn hex_digit(v: u32) -> u8 {
    let v = (v & 0xf) as u8;
    if v < 10 {
        b'0' + v
    } else {
        b'a' + (v - 10)
    }
}
