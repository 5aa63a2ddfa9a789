//! `can-bridge monitor`: a receiving ECU for the bridge's warnings. A second socket that decodes
//! every warning frame, verifies its E2E protection (CRC, alive counter), and measures the latency
//! from the object frame that triggered it (same track) to the warning frame.
use crate::map::CompiledMap;
use crate::socket::{self, SocketError};
use can_codec::{E2eChecker, E2eConfig, E2eStatus, Frame};
use socketcan::Socket;
use std::collections::HashMap;
use std::io::Write;
use std::time::{Duration, Instant};

/// How long to listen and where to write the received warnings.
#[derive(Clone, Debug)]
pub struct MonitorOptions {
    pub iface: String,
    pub duration: Option<Duration>,
    pub idle_exit: Option<Duration>,
}

/// What the monitor saw.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MonitorReport {
    pub triggers: u64,
    pub warnings: u64,
    pub ok: u64,
    pub lost_frames: u64,
    pub repeated: u64,
    pub wrong_sequence: u64,
    pub corrupted: u64,
    /// Trigger-to-warning latency per warning frame (us), in arrival order.
    pub latencies_us: Vec<u64>,
}

impl MonitorReport {
    /// True when every warning frame passed its E2E check.
    pub fn all_protected_ok(&self) -> bool {
        self.repeated == 0
            && self.wrong_sequence == 0
            && self.corrupted == 0
            && self.lost_frames == 0
    }

    /// The `q`-quantile (0..=1) of the latencies, nearest rank.
    pub fn latency_quantile(&self, q: f64) -> Option<u64> {
        let mut v = self.latencies_us.clone();
        if v.is_empty() {
            return None;
        }
        v.sort_unstable();
        let rank = ((q * v.len() as f64).ceil() as usize).clamp(1, v.len());
        Some(v[rank - 1])
    }

    pub fn summary(&self) -> String {
        let q = |x: f64| {
            self.latency_quantile(x)
                .map_or("-".to_string(), |v| format!("{v} us"))
        };
        format!(
            "monitor: {} warning frames ({} ok, {} lost, {} repeated, {} wrong sequence, {} corrupted); {} trigger frames; latency trigger->warning p50 {}, p99 {}, max {}",
            self.warnings,
            self.ok,
            self.lost_frames,
            self.repeated,
            self.wrong_sequence,
            self.corrupted,
            self.triggers,
            q(0.5),
            q(0.99),
            q(1.0),
        )
    }
}

/// Listens until `duration`/`idle_exit`; writes each warning frame as a candump -L line to `out`.
pub fn run(
    map: &CompiledMap,
    opts: &MonitorOptions,
    out: &mut dyn Write,
) -> Result<MonitorReport, SocketError> {
    let w = &map.warning;
    let trigger = map.inputs.iter().find(|m| m.is_trigger);
    let mut ids = vec![w.spec.id];
    if let Some(t) = trigger {
        ids.push(t.spec.id);
    }
    let sock = socket::open_bridge_socket(&opts.iface, &ids, Duration::from_millis(100))?;
    eprintln!("monitor: listening on {}", opts.iface);
    let mut checker = E2eChecker::new(E2eConfig {
        data_id: w.data_id,
        crc_byte: w.crc_byte,
        counter_byte: w.counter_byte,
        max_delta: 15,
    });
    let mut report = MonitorReport::default();
    let mut last_trigger: HashMap<u32, u64> = HashMap::new();
    let started = Instant::now();
    let mut last_frame = Instant::now();
    let mut line = String::new();
    loop {
        match sock.read_frame_with_timestamp() {
            Ok((raw, ts)) => {
                last_frame = Instant::now();
                let t_us = socket::micros(ts);
                let Some(frame) = socket::from_socketcan(&raw) else {
                    continue;
                };
                if frame.is_error() {
                    continue;
                }
                if let Some(t) = trigger.filter(|t| t.spec.id == frame.id) {
                    if let Some(track) = t
                        .track_id
                        .and_then(|s| t.spec.value(s, frame.data()).ok().flatten())
                    {
                        report.triggers += 1;
                        last_trigger.insert(track as u32, t_us);
                    }
                    continue;
                }
                if frame.id != w.spec.id {
                    continue;
                }
                handle_warning(&frame, t_us, map, &mut checker, &last_trigger, &mut report);
                line.clear();
                can_codec::format_line(&mut line, t_us, &opts.iface, &frame);
                line.push('\n');
                out.write_all(line.as_bytes())
                    .map_err(|cause| SocketError::Io {
                        iface: opts.iface.clone(),
                        what: "writing received warnings",
                        cause,
                    })?;
            }
            Err(e)
                if matches!(
                    e.kind(),
                    std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut
                ) => {}
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(cause) if socket::is_interface_gone(&cause) => {
                return Err(SocketError::Gone {
                    iface: opts.iface.clone(),
                    cause,
                })
            }
            Err(cause) => {
                return Err(SocketError::Io {
                    iface: opts.iface.clone(),
                    what: "receiving",
                    cause,
                })
            }
        }
        if opts.duration.is_some_and(|d| started.elapsed() >= d)
            || opts.idle_exit.is_some_and(|d| last_frame.elapsed() >= d)
        {
            let _ = out.flush();
            return Ok(report);
        }
    }
}

fn handle_warning(
    frame: &Frame,
    t_us: u64,
    map: &CompiledMap,
    checker: &mut E2eChecker,
    last_trigger: &HashMap<u32, u64>,
    report: &mut MonitorReport,
) {
    report.warnings += 1;
    match checker.check(frame.data()) {
        E2eStatus::Initial | E2eStatus::Ok => report.ok += 1,
        E2eStatus::OkSomeLost { lost } => {
            report.ok += 1;
            report.lost_frames += u64::from(lost);
        }
        E2eStatus::Repeated => report.repeated += 1,
        E2eStatus::WrongSequence => report.wrong_sequence += 1,
        E2eStatus::Corrupted => {
            report.corrupted += 1;
            return;
        }
    }
    let w = &map.warning;
    if let Ok(Some(track)) = w.spec.value(w.track_id, frame.data()) {
        if let Some(t) = last_trigger.get(&(track as u32)) {
            report.latencies_us.push(t_us.saturating_sub(*t));
        }
    }
}
