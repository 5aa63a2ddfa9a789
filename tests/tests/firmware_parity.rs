//! The Cortex-M4F firmware (tests/firmware) computes exactly what the host computes.
//!
//! Builds the firmware (release, thumbv7em-none-eabihf), runs it under
//! `qemu-system-arm -M mps2-an386` with semihosting, and recomputes every reported number on the
//! host with `scorer-core` from the very model bytes and input bits the firmware used:
//! - int8 DRL scores and every warning decision (track table replay): bit-exact;
//! - features, surrogates and MSRA scores: within 1e-5 relative (infinities must match);
//! - the inputs are the golden rows they claim to be (tests/data/golden_surrogates.csv);
//! - the C ABI path and the deployed per-partner path agree with the staged core path on the MCU;
//! - the run ends with exit code 0, never the panic handler's code 101, and statically the linked
//!   image contains no panic machinery at all (`rust_begin_unwind`, `riskscore_panic`): the
//!   optimiser proved every panic path of the core, the C ABI and the firmware unreachable.
//!
//! Needs `qemu-system-arm` and the `thumbv7em-none-eabihf` target (`scripts/setup.sh test`).
use std::collections::{HashMap, HashSet};
use std::io::Read;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use scorer_core::model::{self, Model};
use scorer_core::warning::{TrackTable, WarningConfig, WarningEvent};
use scorer_core::{
    box_distance, drl_inputs, ei, features, tadv, tadv_corridor, ttc2d, Observation, Surrogates,
    VehicleState,
};

const EXIT_PANIC: i32 = 101;
const QEMU_TIMEOUT: Duration = Duration::from_secs(120);
const REL_TOL: f32 = 1e-5;
const MAX_TRACKS: usize = 32;

fn repo_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("tests/ has a parent")
        .to_path_buf()
}

/// Builds the firmware and returns the ELF path.
pub fn build_firmware(root: &Path) -> PathBuf {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let target_dir = root.join("target/firmware");
    let output = Command::new(cargo)
        .current_dir(root.join("tests/firmware"))
        .args([
            "build",
            "--release",
            "--quiet",
            "--target",
            "thumbv7em-none-eabihf",
        ])
        .arg("--target-dir")
        .arg(&target_dir)
        // The outer test run's flags are for the host; the firmware has its own profile.
        .env_remove("RUSTFLAGS")
        .env_remove("CARGO_ENCODED_RUSTFLAGS")
        .env_remove("CARGO_BUILD_RUSTFLAGS")
        .env_remove("CARGO_TARGET_DIR")
        .output()
        .expect("running cargo to build tests/firmware");
    assert!(
        output.status.success(),
        "building tests/firmware failed (is the thumbv7em-none-eabihf target installed? run \
         scripts/setup.sh test):\n{}",
        String::from_utf8_lossy(&output.stderr)
    );
    target_dir.join("thumbv7em-none-eabihf/release/riskscore-firmware")
}

/// Runs the firmware under QEMU; returns (exit code, stdout).
pub fn run_qemu(elf: &Path, append: &str) -> (i32, String) {
    let mut cmd = Command::new("qemu-system-arm");
    cmd.args(["-M", "mps2-an386", "-nographic"])
        .args(["-semihosting-config", "enable=on,target=native"])
        .arg("-kernel")
        .arg(elf);
    if !append.is_empty() {
        cmd.args(["-append", append]);
    }
    let mut child = cmd
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::inherit())
        .spawn()
        .unwrap_or_else(|e| {
            panic!("cannot start qemu-system-arm ({e}); install it with scripts/setup.sh test")
        });
    let mut stdout = child.stdout.take().expect("piped stdout");
    let reader = std::thread::spawn(move || {
        let mut s = String::new();
        stdout.read_to_string(&mut s).map(|_| s)
    });
    let start = Instant::now();
    let status = loop {
        if let Some(status) = child.try_wait().expect("waiting for qemu") {
            break status;
        }
        if start.elapsed() > QEMU_TIMEOUT {
            let _ = child.kill();
            let _ = child.wait();
            panic!("firmware did not finish within {QEMU_TIMEOUT:?} (hang or HardFault loop)");
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    let out = reader
        .join()
        .expect("reader thread")
        .expect("qemu stdout is UTF-8");
    (status.code().unwrap_or(-1), out)
}

fn hex_f32(tok: &str, what: &str, line: &str) -> f32 {
    let bits = u32::from_str_radix(tok, 16)
        .unwrap_or_else(|e| panic!("bad {what} token {tok:?} ({e}) in firmware line: {line}"));
    f32::from_bits(bits)
}

fn close(a: f32, b: f32) -> bool {
    if a.to_bits() == b.to_bits() || a == b {
        return true;
    }
    if !(a.is_finite() && b.is_finite()) {
        return false;
    }
    (a - b).abs() <= REL_TOL * a.abs().max(b.abs())
}

/// Golden CSV: line number -> (ego, partner) as parsed from the text.
fn golden_inputs(root: &Path) -> HashMap<u32, [f32; 18]> {
    let path = root.join("tests/data/golden_surrogates.csv");
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().expect("header").split(',').collect();
    let mut cols = Vec::new();
    for side in ["i", "j"] {
        for f in ["x", "y", "vx", "vy", "hx", "hy", "acc", "length", "width"] {
            let name = format!("{f}_{side}");
            let c = header
                .iter()
                .position(|h| *h == name)
                .unwrap_or_else(|| panic!("{}: no column {name}", path.display()));
            cols.push(c);
        }
    }
    let mut rows = HashMap::new();
    for (i, line) in lines.enumerate() {
        let fields: Vec<&str> = line.split(',').collect();
        let mut v = [0f32; 18];
        for (slot, &c) in v.iter_mut().zip(&cols) {
            *slot = fields[c].parse().unwrap_or_else(|e| {
                panic!("{} line {}: {:?}: {e}", path.display(), i + 2, fields[c])
            });
        }
        rows.insert(i as u32 + 2, v);
    }
    rows
}

fn state(v: &[f32]) -> VehicleState {
    VehicleState {
        x: v[0],
        y: v[1],
        vx: v[2],
        vy: v[3],
        hx: v[4],
        hy: v[5],
        acc: v[6],
        length: v[7],
        width: v[8],
    }
}

fn event_code(e: WarningEvent) -> u32 {
    match e {
        WarningEvent::None => 0,
        WarningEvent::Onset => 1,
        WarningEvent::Release => 2,
    }
}

#[test]
fn firmware_on_cortex_m4f_matches_host() {
    let root = repo_root();
    let elf = build_firmware(&root);
    let symbols = Command::new("readelf")
        .args(["-sW"])
        .arg(&elf)
        .output()
        .expect("running readelf (binutils)");
    let symbols = String::from_utf8_lossy(&symbols.stdout);
    for panic_symbol in ["rust_begin_unwind", "riskscore_panic", "panic_fmt"] {
        assert!(
            !symbols.contains(panic_symbol),
            "{} links `{panic_symbol}`: some code in the image can panic (find the caller with \
             `arm-none-eabi-objdump -d` and remove the panic path)",
            elf.display()
        );
    }
    let (code, out) = run_qemu(&elf, "");
    assert_ne!(
        code, EXIT_PANIC,
        "the firmware's panic handler ran (exit {EXIT_PANIC}); output:\n{out}"
    );
    assert_eq!(code, 0, "firmware exit code {code}; output:\n{out}");

    // Model blobs, exactly as embedded.
    let mut blobs: HashMap<String, Vec<u8>> = HashMap::new();
    let mut declared: HashMap<String, (usize, u32, String)> = HashMap::new();
    for line in out.lines() {
        let t: Vec<&str> = line.split(' ').collect();
        match t[0] {
            "MODEL" => {
                let len = t[3].parse().expect("MODEL length");
                let crc = u32::from_str_radix(t[4], 16).expect("MODEL crc");
                declared.insert(t[1].into(), (len, crc, t[5..].join(" ")));
            }
            "BLOB" => {
                let offset: usize = t[2].parse().expect("BLOB offset");
                let blob = blobs.entry(t[1].into()).or_default();
                assert_eq!(blob.len(), offset, "BLOB chunks out of order: {line}");
                for pair in t[3].as_bytes().chunks(2) {
                    let s = std::str::from_utf8(pair).expect("hex");
                    blob.push(u8::from_str_radix(s, 16).expect("BLOB hex"));
                }
            }
            "ERROR" => panic!("firmware reported: {line}"),
            _ => {}
        }
    }
    for slot in ["drl", "msra"] {
        let (len, crc, source) = declared
            .get(slot)
            .unwrap_or_else(|| panic!("no MODEL {slot} line in:\n{out}"));
        let blob = &blobs[slot];
        assert_eq!(blob.len(), *len, "{slot}: dumped blob length");
        let header = model::decode_header(blob).expect("dumped blob header");
        assert_eq!(header.payload_crc, *crc, "{slot}: payload CRC");
        // When a shipped model exists, the firmware must embed exactly it.
        let shipped = root.join(format!("models/{slot}-default.rsk"));
        if shipped.exists() {
            let shipped_bytes = std::fs::read(&shipped).expect("read shipped model");
            // The DRL blob is guarded by the blend policy (build.rs): the same model and
            // threshold, the shipped ranges and blend weight if any, and the MSRA's kinematic
            // terms as fallback.
            let embedded = model::decode_blob(blob).expect("embedded blob");
            let original = model::decode_blob(&shipped_bytes).expect("shipped blob");
            if slot == "drl" {
                let domain = embedded.meta.training_domain.expect("a training domain");
                assert_eq!(domain.policy, model::OutsidePolicy::Blend);
                assert!(embedded.meta.kinematic_fallback.is_some());
                if let Some(shipped_blend) = original.meta.blend {
                    assert_eq!(embedded.meta.blend, Some(shipped_blend));
                }
                if let Some(shipped_domain) = original.meta.training_domain {
                    assert_eq!(domain.range_bytes, shipped_domain.range_bytes);
                }
                assert_eq!(
                    embedded.model, original.model,
                    "firmware embeds another model"
                );
                assert_eq!(
                    embedded.meta.default_threshold,
                    original.meta.default_threshold
                );
                assert_eq!(
                    source,
                    &format!("models/{slot}-default.rsk + blend guard (build.rs)")
                );
            } else {
                assert_eq!(
                    &shipped_bytes,
                    blob,
                    "firmware embeds a different blob than {}",
                    shipped.display()
                );
                assert_eq!(source, &format!("models/{slot}-default.rsk"));
            }
        }
    }
    let drl = model::decode(&blobs["drl"]).expect("host decodes the DRL blob");
    let drl_guarded = model::decode_blob(&blobs["drl"]).expect("host decodes the DRL blob");
    assert!(
        drl_guarded.meta.training_domain.is_some(),
        "the firmware's DRL blob must carry a training domain (the guard is part of the budget)"
    );
    let (mut inside, mut outside, mut outside_by_geometry) = (0usize, 0usize, 0usize);
    let msra = model::decode(&blobs["msra"]).expect("host decodes the MSRA blob");
    assert!(
        matches!(drl, Model::DrlInt8(_)),
        "the DRL slot must hold an int8 network"
    );

    // Warning configuration.
    let cfg_line = out
        .lines()
        .find(|l| l.starts_with("CONFIG "))
        .expect("CONFIG line");
    let c: Vec<&str> = cfg_line.split(' ').collect();
    let config = WarningConfig::live(
        hex_f32(c[1], "threshold", cfg_line),
        hex_f32(c[2], "hysteresis", cfg_line),
        c[3].parse().expect("min_on_us"),
        c[4].parse().expect("stale_after_us"),
    );
    let mut table = TrackTable::<MAX_TRACKS>::new(config).expect("config valid on the host");

    let golden = golden_inputs(&root);
    let mut records = 0;
    let mut exact_floats = 0usize;
    let mut total_floats = 0usize;
    let (mut onsets, mut releases, mut recreated) = (0, 0, 0);
    let mut seen_ids = HashSet::new();
    for line in out.lines().filter(|l| l.starts_with("R ")) {
        records += 1;
        let t: Vec<&str> = line.split(' ').collect();
        let at = |tag: &str| {
            t.iter()
                .position(|x| *x == tag)
                .unwrap_or_else(|| panic!("no {tag} in {line}"))
        };
        let csv_line: u32 = t[1].parse().expect("csv line");
        let input: Vec<f32> = t[at("I") + 1..at("I") + 19]
            .iter()
            .map(|x| hex_f32(x, "input", line))
            .collect();
        let expected_input = golden.get(&csv_line).unwrap_or_else(|| {
            panic!("firmware names golden line {csv_line}, which does not exist")
        });
        for (k, (a, b)) in input.iter().zip(expected_input.iter()).enumerate() {
            assert_eq!(
                a.to_bits(),
                b.to_bits(),
                "golden line {csv_line}: input {k} embedded wrongly"
            );
        }
        let (ego, partner) = (state(&input[..9]), state(&input[9..]));

        let fw_f: Vec<f32> = t[at("F") + 1..at("F") + 14]
            .iter()
            .map(|x| hex_f32(x, "feature", line))
            .collect();
        let host_f = features(&ego, &partner);
        for (k, (a, b)) in fw_f.iter().zip(host_f.iter()).enumerate() {
            assert!(
                close(*a, *b),
                "golden line {csv_line}: feature {} ({}) MCU {a:e} vs host {b:e}",
                k,
                scorer_core::FEATURE_NAMES[k]
            );
            exact_floats += usize::from(a.to_bits() == b.to_bits());
            total_floats += 1;
        }
        let fw_s: Vec<f32> = t[at("S") + 1..at("S") + 6]
            .iter()
            .map(|x| hex_f32(x, "surrogate", line))
            .collect();
        let host_s = Surrogates {
            box_distance: box_distance(&ego, &partner),
            ttc2d: ttc2d(&ego, &partner),
            tadv: tadv(&ego, &partner),
            tadv_corridor: tadv_corridor(&ego, &partner),
            ei: ei(&ego, &partner),
        };
        let names = ["box_distance", "ttc2d", "tadv", "ei", "tadv_corridor"];
        let host_sv = [
            host_s.box_distance,
            host_s.ttc2d,
            host_s.tadv,
            host_s.ei,
            host_s.tadv_corridor,
        ];
        for k in 0..5 {
            assert!(
                close(fw_s[k], host_sv[k]),
                "golden line {csv_line}: {} MCU {:e} vs host {:e}",
                names[k],
                fw_s[k],
                host_sv[k]
            );
            exact_floats += usize::from(fw_s[k].to_bits() == host_sv[k].to_bits());
            total_floats += 1;
        }

        // DRL inputs (encoding 3, from the states): bit-exact, they feed the int8 network.
        let fw_x: Vec<f32> = t[at("X") + 1..at("X") + 14]
            .iter()
            .map(|x| hex_f32(x, "drl input", line))
            .collect();
        let host_x = drl_inputs(&ego, &partner);
        for (k, (a, b)) in fw_x.iter().zip(host_x.iter()).enumerate() {
            assert_eq!(
                a.to_bits(),
                b.to_bits(),
                "golden line {csv_line}: DRL input {} ({}) MCU {a:e} vs host {b:e} (must be bit-exact)",
                k,
                scorer_core::DRL_INPUT_NAMES[k]
            );
        }
        let host_o = Observation {
            features: host_f,
            surrogates: host_s,
            drl_inputs: host_x,
        };
        assert_eq!(
            host_o,
            Observation::of(&ego, &partner),
            "golden line {csv_line}: Observation::of differs from its parts"
        );

        // Scores: the host scores the host's own observation.
        let d = hex_f32(t[at("D") + 1], "drl", line);
        let host_d = drl.score_observation(&host_o);
        assert_eq!(
            host_d.to_bits(),
            drl.score(&ego, &partner).to_bits(),
            "golden line {csv_line}: Model::score and score_observation differ on the host"
        );
        assert_eq!(
            d.to_bits(),
            host_d.to_bits(),
            "golden line {csv_line}: int8 DRL score MCU {d:e} vs host {host_d:e} (must be bit-exact)"
        );
        // The guarded score of the deployed path: bit-exact, same flag, same first input outside.
        let g = at("G");
        let fw_g = hex_f32(t[g + 1], "guarded drl", line);
        let host_g = drl_guarded.score_guarded(&host_o);
        assert_eq!(
            fw_g.to_bits(),
            host_g.score.to_bits(),
            "golden line {csv_line}: guarded DRL score MCU {fw_g:e} vs host {:e}",
            host_g.score
        );
        assert_eq!(
            (t[g + 2], t[g + 3]),
            (
                if host_g.in_domain { "1" } else { "0" },
                host_g
                    .first_outside
                    .map_or("-".to_string(), |i| i.to_string())
                    .as_str()
            ),
            "golden line {csv_line}: domain flag / first input outside differ"
        );
        if host_g.in_domain {
            inside += 1;
        } else {
            outside += 1;
        }
        if host_g.first_outside == Some(model::GEOMETRY_INPUT) {
            outside_by_geometry += 1;
        }
        let m = hex_f32(t[at("M") + 1], "msra", line);
        let host_m = msra.score_observation(&host_o);
        assert!(
            close(m, host_m),
            "golden line {csv_line}: MSRA MCU {m:e} vs host {host_m:e}"
        );
        exact_floats += usize::from(m.to_bits() == host_m.to_bits());
        total_floats += 1;

        // Warning decisions: replay the same updates.
        let w = at("W");
        let id: u32 = t[w + 1].parse().expect("track id");
        let now: u64 = t[w + 2].parse().expect("now");
        let st = table.update(id, now, host_d).expect("host update accepted");
        let fw_warning: u32 = t[w + 3].parse().expect("warning");
        let fw_event: u32 = t[w + 4].parse().expect("event");
        let fw_new: u32 = t[w + 5].parse().expect("new");
        let fw_evicted = t[w + 6];
        assert_eq!(
            (fw_warning, fw_event, fw_new),
            (
                u32::from(st.warning),
                event_code(st.event),
                u32::from(st.new_track)
            ),
            "golden line {csv_line}: warning decision for track {id} at {now} us differs"
        );
        assert_eq!(
            fw_evicted,
            st.evicted.map_or("-".to_string(), |v| v.to_string()),
            "golden line {csv_line}: eviction differs"
        );
        onsets += usize::from(st.event == WarningEvent::Onset);
        releases += usize::from(st.event == WarningEvent::Release);
        if st.new_track && !seen_ids.insert(id) {
            recreated += 1;
        }

        assert_eq!(
            t[at("C") + 1],
            "1",
            "golden line {csv_line}: C ABI path disagrees on the MCU"
        );
        assert_eq!(
            t[at("P") + 1],
            "1",
            "golden line {csv_line}: deployed path disagrees on the MCU"
        );
    }
    let done: usize = out
        .lines()
        .find_map(|l| l.strip_prefix("DONE "))
        .expect("DONE line (firmware stopped early)")
        .parse()
        .expect("DONE count");
    assert_eq!(done, records, "DONE count vs result lines");
    assert!(records >= 100, "only {records} inputs scored");
    // Both sides of the guard run on the MCU.
    assert!(
        inside > 0 && outside > 0,
        "inputs inside the domain: {inside}, outside: {outside}"
    );
    // With a geometry coverage, the cell check runs on the MCU too: some input inside every
    // range lies in an uncovered cell.
    if drl_guarded.meta.coverage().is_some() {
        assert!(
            outside_by_geometry > 0,
            "no input outside by its geometry cell ({outside} outside)"
        );
    }
    // The run must exercise the warning logic, or the bit-exact replay proves little.
    assert!(
        onsets > 0 && releases > 0,
        "no onset ({onsets}) or release ({releases})"
    );
    assert!(recreated > 0, "no stale track was dropped and re-created");
    eprintln!(
        "firmware parity: {records} inputs, {onsets} onsets, {releases} releases, {recreated} \
         re-created tracks; {exact_floats}/{total_floats} float outputs bit-identical"
    );
}
