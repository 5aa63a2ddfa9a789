//! The C ABI from C: builds `libscorer_ffi.a` (panic = abort), compiles tests/c/ffi_test.c with gcc
//! (`-Wall -Wextra -Werror -pedantic`) against the checked-in header, and runs it on the golden
//! data. The C program checks every error path and the golden features/surrogates itself; this test
//! then compares every number it printed bit for bit with `scorer-core` on the host (the models'
//! scores and training-domain flags with `ModelBlob::score_guarded`), checks a pair inside and a
//! pair outside the DRL's domain with the blob as given and with its records stripped, and
//! replays the warning sequence through a host `TrackTable`.
use std::path::{Path, PathBuf};
use std::process::Command;

use scorer_core::model::{self, ModelBlob};
use scorer_core::warning::{TrackTable, WarningConfig, WarningEvent};
use scorer_core::{Guarded, Observation, VehicleState};

#[path = "../firmware/test_models.rs"]
#[allow(dead_code)]
mod test_models;

fn repo_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("tests/ has a parent")
        .to_path_buf()
}

/// `models/<name>-default.rsk` when shipped, else the deterministic stand-in (same rule as the
/// firmware build script).
fn model_blob(root: &Path, name: &str) -> Vec<u8> {
    let shipped = root.join(format!("models/{name}-default.rsk"));
    if shipped.exists() {
        return std::fs::read(&shipped).unwrap_or_else(|e| panic!("{}: {e}", shipped.display()));
    }
    match name {
        "drl" => test_models::drl_int8(),
        _ => test_models::msra(),
    }
}

fn run(cmd: &mut Command, what: &str) -> std::process::Output {
    let out = cmd
        .output()
        .unwrap_or_else(|e| panic!("{what}: cannot run {cmd:?}: {e}"));
    assert!(
        out.status.success(),
        "{what} failed ({}):\n{}\n{}",
        out.status,
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

/// What a C program links after `libscorer_ffi.a` on Linux: the system libraries a Rust
/// staticlib needs.
const STATICLIB_SYSTEM_LIBS: [&str; 7] = [
    "-lgcc_s",
    "-lutil",
    "-lrt",
    "-lpthread",
    "-lm",
    "-ldl",
    "-lc",
];

/// `libscorer_ffi.a` built into `out_dir` exactly as a C integrator builds it; its path.
fn build_staticlib(root: &Path, out_dir: &Path) -> PathBuf {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    run(
        Command::new(&cargo)
            .current_dir(root)
            .args(["rustc", "--quiet", "-p", "scorer-ffi", "--release", "--lib"])
            .args(["--crate-type", "staticlib", "--target-dir"])
            .arg(out_dir)
            .args(["--", "-C", "panic=abort"])
            .env_remove("RUSTFLAGS")
            .env_remove("CARGO_ENCODED_RUSTFLAGS")
            .env_remove("CARGO_TARGET_DIR"),
        "building libscorer_ffi.a",
    );
    let lib = out_dir.join("release/libscorer_ffi.a");
    assert!(lib.exists(), "{} missing after the build", lib.display());
    lib
}

/// The first C block of docs/ecu.md's "The API in one page".
fn ecu_md_example(root: &Path) -> String {
    let doc = std::fs::read_to_string(root.join("docs/ecu.md")).expect("docs/ecu.md");
    let section = doc
        .split("## The API in one page")
        .nth(1)
        .expect("docs/ecu.md has 'The API in one page'");
    section
        .split("```c\n")
        .nth(1)
        .and_then(|rest| rest.split("```").next())
        .expect("a ```c block in 'The API in one page'")
        .to_string()
}

fn bits(tok: &str) -> u32 {
    u32::from_str_radix(tok, 16).unwrap_or_else(|e| panic!("bad hex {tok:?}: {e}"))
}

fn golden_states(root: &Path) -> Vec<(usize, VehicleState, VehicleState)> {
    let path = root.join("tests/data/golden_surrogates.csv");
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().expect("header").split(',').collect();
    let col = |n: &str| {
        header
            .iter()
            .position(|h| *h == n)
            .unwrap_or_else(|| panic!("no column {n}"))
    };
    let names = ["x", "y", "vx", "vy", "hx", "hy", "acc", "length", "width"];
    let cols: Vec<usize> = ["i", "j"]
        .iter()
        .flat_map(|s| names.iter().map(move |f| format!("{f}_{s}")))
        .map(|n| col(&n))
        .collect();
    lines
        .enumerate()
        .map(|(i, line)| {
            let f: Vec<&str> = line.split(',').collect();
            let v: Vec<f32> = cols
                .iter()
                .map(|&c| {
                    f[c].parse()
                        .unwrap_or_else(|e| panic!("line {}: {e}", i + 2))
                })
                .collect();
            (i + 2, state_at(&v, 0), state_at(&v, 9))
        })
        .collect()
}

/// The state of the nine values at `v[o..]`, in `VehicleState` field order.
fn state_at(v: &[f32], o: usize) -> VehicleState {
    VehicleState {
        x: v[o],
        y: v[o + 1],
        vx: v[o + 2],
        vy: v[o + 3],
        hx: v[o + 4],
        hy: v[o + 5],
        acc: v[o + 6],
        length: v[o + 7],
        width: v[o + 8],
    }
}

#[test]
fn c_program_links_staticlib_and_matches_host() {
    let root = repo_root();
    let out_dir = root.join("target/ffi-c");
    // 1. The static library, exactly as a C integrator builds it.
    let lib = build_staticlib(&root, &out_dir);

    // 2. The C program (strict C11, warnings are errors).
    let exe = out_dir.join("ffi_test");
    run(
        Command::new("gcc")
            .args([
                "-std=c11",
                "-D_DEFAULT_SOURCE",
                "-O2",
                "-Wall",
                "-Wextra",
                "-Werror",
            ])
            .args([
                "-pedantic",
                "-Wconversion",
                "-Wno-sign-conversion",
                "-Wno-float-conversion",
            ])
            .arg("-I")
            .arg(root.join("scorer-core/ffi/include"))
            .arg(root.join("tests/c/ffi_test.c"))
            .arg(&lib)
            .args(STATICLIB_SYSTEM_LIBS)
            .arg("-o")
            .arg(&exe),
        "compiling tests/c/ffi_test.c with gcc",
    );

    // 3. Inputs: model blobs and a threshold inside the score range (median of the first rows).
    let drl_blob = model_blob(&root, "drl");
    let msra_blob = model_blob(&root, "msra");
    let drl = model::decode_blob(&drl_blob).expect("DRL blob decodes");
    let msra = model::decode_blob(&msra_blob).expect("MSRA blob decodes");
    let unguarded_drl = ModelBlob::from(drl.model.clone());
    let mut unguarded_blob = vec![0u8; model::encoded_blob_len(&unguarded_drl).expect("length")];
    model::encode_blob(&unguarded_drl, &mut unguarded_blob).expect("the stripped DRL encodes");
    let states = golden_states(&root);
    let mut sample: Vec<f32> = states
        .iter()
        .take(101)
        .map(|(_, e, p)| drl.score_pair_guarded(e, p).score)
        .collect();
    sample.sort_by(f32::total_cmp);
    let threshold = sample[sample.len() / 2];
    let drl_path = out_dir.join("drl.rsk");
    let msra_path = out_dir.join("msra.rsk");
    std::fs::write(&drl_path, &drl_blob).expect("write drl.rsk");
    std::fs::write(&msra_path, &msra_blob).expect("write msra.rsk");
    let unguarded_path = out_dir.join("drl-unguarded.rsk");
    std::fs::write(&unguarded_path, &unguarded_blob).expect("write drl-unguarded.rsk");

    let output = Command::new(&exe)
        .arg(root.join("tests/data/golden_surrogates.csv"))
        .arg(&drl_path)
        .arg(&msra_path)
        .arg(format!("{threshold}"))
        .arg(&unguarded_path)
        .output()
        .expect("running ffi_test");
    let stdout = String::from_utf8_lossy(&output.stdout);
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(
        output.status.success(),
        "the C test failed ({}):\n{}",
        output.status,
        stderr
    );
    eprint!(
        "{}",
        stderr
            .lines()
            .filter(|l| l.starts_with("golden"))
            .collect::<Vec<_>>()
            .join("\n")
    );
    eprintln!();
    assert_eq!(stdout.lines().last(), Some("OK"), "C test did not finish");

    // 4. Bit-exact against the host core.
    let by_line: std::collections::HashMap<usize, (VehicleState, VehicleState)> =
        states.iter().map(|(l, e, p)| (*l, (*e, *p))).collect();
    let cfg_line = stdout
        .lines()
        .find(|l| l.starts_with("C "))
        .expect("C config line");
    let c: Vec<&str> = cfg_line.split(' ').collect();
    let config = WarningConfig::live(
        f32::from_bits(bits(c[2])),
        f32::from_bits(bits(c[4])),
        100_000,
        1_000_000,
    );
    assert_eq!(
        config.threshold.to_bits(),
        threshold.to_bits(),
        "threshold passed to C"
    );
    let mut table = TrackTable::<32>::new(config).expect("config");
    let (mut rows, mut onsets, mut releases, mut outside) = (0, 0, 0, 0);
    let mut guard_lines = 0;
    let mut last_drl = 0u32;
    for line in stdout.lines() {
        let t: Vec<&str> = line.split(' ').collect();
        match t[0] {
            "P" => {
                rows += 1;
                let n: usize = t[1].parse().expect("line number");
                let (ego, partner) = by_line[&n];
                let o = Observation::of(&ego, &partner);
                let s = o.surrogates;
                let (d, m) = (drl.score_guarded(&o), msra.score_guarded(&o));
                let host: Vec<f32> = o
                    .features
                    .iter()
                    .copied()
                    .chain([s.box_distance, s.ttc2d, s.tadv, s.ei])
                    .chain([d.score, m.score])
                    .collect();
                for (k, (tok, h)) in t[2..].iter().zip(&host).enumerate() {
                    assert_eq!(
                        bits(tok),
                        h.to_bits(),
                        "golden line {n}: value {k} via C = {:e}, host core = {h:e}",
                        f32::from_bits(bits(tok))
                    );
                }
                assert_eq!(t.len() - 4, host.len(), "golden line {n}: value count");
                let flags = [d.in_domain, m.in_domain].map(|inside| u8::from(inside).to_string());
                assert_eq!(
                    t[t.len() - 2..],
                    flags,
                    "golden line {n}: DRL and MSRA in-domain flags via C vs host"
                );
                outside += usize::from(!d.in_domain);
                last_drl = host[17].to_bits();
            }
            "T" => {
                let id: u32 = t[1].parse().expect("id");
                let now: u64 = t[2].parse().expect("now");
                assert_eq!(bits(t[3]), last_drl, "track update fed a different score");
                let st = table
                    .update(id, now, f32::from_bits(bits(t[3])))
                    .expect("host update");
                let event = match st.event {
                    WarningEvent::None => 0,
                    WarningEvent::Onset => 1,
                    WarningEvent::Release => 2,
                };
                let evicted = st.evicted.unwrap_or(u32::MAX);
                let expected = format!(
                    "{} {} {} {}",
                    u8::from(st.warning),
                    event,
                    u8::from(st.new_track),
                    evicted
                );
                assert_eq!(t[4..].join(" "), expected, "warning decision at {line}");
                onsets += usize::from(st.event == WarningEvent::Onset);
                releases += usize::from(st.event == WarningEvent::Release);
            }
            "G" => {
                guard_lines += 1;
                check_guard_line(&t, &drl, &unguarded_drl, &msra);
            }
            _ => {}
        }
    }
    assert_eq!(rows, states.len(), "every golden row scored through C");
    assert_eq!(
        guard_lines, 4,
        "guard lines: inside/outside x given/unguarded"
    );
    eprintln!("golden rows outside the DRL's training domain (host and C agree): {outside}");
    assert!(
        outside > 0 && outside < rows,
        "the golden rows must lie on both sides of the DRL's training domain ({outside} of {rows} outside)"
    );
    assert!(
        onsets > 0 && releases > 0,
        "warning sequence without onset/release"
    );
}

/// A `G <pair> <given|unguarded> <18 state bits> <drl bits> <drl in> <msra bits> <msra in>` line
/// against the host's guarded scores of the same states: the pair named "outside" must be outside
/// the DRL's domain (else the line checks nothing), the stripped blob inside everywhere with the
/// network's own score.
fn check_guard_line(
    t: &[&str],
    drl: &ModelBlob<'_>,
    unguarded: &ModelBlob<'_>,
    msra: &ModelBlob<'_>,
) {
    assert_eq!(t.len(), 25, "guard line fields: {t:?}");
    let v: Vec<f32> = t[3..21]
        .iter()
        .map(|tok| f32::from_bits(bits(tok)))
        .collect();
    let (ego, partner) = (state_at(&v, 0), state_at(&v, 9));
    let o = Observation::of(&ego, &partner);
    let blob = match t[2] {
        "given" => drl,
        "unguarded" => unguarded,
        other => panic!("unknown blob set {other:?}"),
    };
    let d = blob.score_guarded(&o);
    let host_drl = drl.score_guarded(&o);
    // The stand-in DRL (no shipped blob) has no record: inside everywhere.
    let guarded = drl.meta.training_domain.is_some();
    assert_eq!(
        host_drl.in_domain,
        t[1] == "inside" || !guarded,
        "the {} pair is {} the DRL's domain on the host",
        t[1],
        if host_drl.in_domain {
            "inside"
        } else {
            "outside"
        }
    );
    let render = |g: &Guarded| format!("{:08x} {}", g.score.to_bits(), u8::from(g.in_domain));
    let msra_expected = match t[2] {
        "given" => render(&msra.score_guarded(&o)),
        _ => format!("{:08x} 1", f32::NAN.to_bits()),
    };
    assert_eq!(
        t[21..].join(" "),
        format!("{} {msra_expected}", render(&d)),
        "{} pair, {} blobs: C vs host score_guarded (DRL bits, flag, MSRA bits, flag)",
        t[1],
        t[2]
    );
    if t[2] == "unguarded" {
        assert!(d.in_domain);
        assert_eq!(d.score.to_bits(), drl.model.score_observation(&o).to_bits());
    }
}

/// The C example of docs/ecu.md ("The API in one page") is a compilation unit a firmware engineer
/// can copy: it compiles against the checked-in header as strict C99 with warnings as errors. It
/// was a fragment that went on with an unwritten `threshold` after a failed
/// `riskscore_model_default_threshold` and switched its warning on at ONSET only (a warning also
/// ends without a RELEASE event: stale track, reset time base).
#[test]
fn ecu_md_api_example_compiles() {
    let root = repo_root();
    let example = ecu_md_example(&root);
    assert!(
        !example.contains("ONSET) raise_warning"),
        "the example drives its output from the state, not from ONSET alone"
    );
    let out_dir = root.join("target/ffi-c");
    std::fs::create_dir_all(&out_dir).expect("target/ffi-c");
    let src = out_dir.join("ecu_md_example.c");
    std::fs::write(&src, example).expect("write the example");
    run(
        Command::new("gcc")
            .args([
                "-std=c99",
                "-O2",
                "-Wall",
                "-Wextra",
                "-Werror",
                "-pedantic",
            ])
            .args(["-Wconversion", "-Wno-sign-conversion"])
            .arg("-I")
            .arg(root.join("scorer-core/ffi/include"))
            .arg("-c")
            .arg(&src)
            .arg("-o")
            .arg(out_dir.join("ecu_md_example.o")),
        "compiling the C example of docs/ecu.md",
    );
}

/// The same example, linked against `libscorer_ffi.a` with a harness that provides what it
/// declares (the shipped DRL blob as `drl_model`, `log_error`, `set_warning`) and runs it: a
/// partner closing from 150 m turns the output on, one pulling away turns it off again; a
/// corrupted blob makes `risk_start` fail (non-zero) instead of running on.
#[test]
fn ecu_md_api_example_runs() {
    let root = repo_root();
    // The directory and library of c_program_links_staticlib_and_matches_host (one build).
    let out_dir = root.join("target/ffi-c");
    let lib = build_staticlib(&root, &out_dir);
    let example = ecu_md_example(&root);
    std::fs::write(out_dir.join("example.c"), example).expect("write the example");
    let blob = model_blob(&root, "drl");
    for corrupt in [false, true] {
        let mut bytes = blob.clone();
        if corrupt {
            let last = bytes.len() - 1;
            bytes[last] ^= 1;
        }
        let array: Vec<String> = bytes.iter().map(|b| b.to_string()).collect();
        let harness = format!(
            r#"#include "riskscore.h"
#include <stdio.h>
int risk_start(void);
void risk_partner(uint32_t partner_id, uint64_t now_us, const RiskscoreVehicleState *ego,
                  const RiskscoreVehicleState *partner);
const uint8_t drl_model[] = {{{}}};
const size_t drl_model_len = sizeof drl_model;
static int on = -1, ever_on = 0;
void log_error(const char *what, const char *why, const char *field) {{
    printf("log %s: %s [%s]\n", what, why, field);
}}
void set_warning(uint32_t partner_id, int v) {{ (void)partner_id; on = v; ever_on |= v; }}
int main(void) {{
    if (risk_start() != 0) return 10;
    RiskscoreVehicleState ego = {{0, 0, 25, 0, 1, 0, 0, 4.5f, 1.8f}};
    for (int f = 0; f < 60; f++) {{
        RiskscoreVehicleState p = {{150.0f - 2.0f * (float)f, 0, 5, 0, 1, 0, 0, 4.5f, 1.8f}};
        risk_partner(7, (uint64_t)f * 100000u, &ego, &p);
    }}
    if (!ever_on) return 11;
    for (int f = 60; f < 100; f++) {{
        RiskscoreVehicleState p = {{200.0f + 10.0f * (float)f, 0, 40, 0, 1, 0, 0, 4.5f, 1.8f}};
        risk_partner(7, (uint64_t)f * 100000u, &ego, &p);
    }}
    if (on != 0) return 12;
    printf("ok\n");
    return 0;
}}
"#,
            array.join(",")
        );
        std::fs::write(out_dir.join("harness.c"), harness).expect("write the harness");
        let exe = out_dir.join("example");
        run(
            Command::new("gcc")
                .args([
                    "-std=c99",
                    "-O2",
                    "-Wall",
                    "-Wextra",
                    "-Werror",
                    "-pedantic",
                ])
                .arg("-I")
                .arg(root.join("scorer-core/ffi/include"))
                .arg(out_dir.join("example.c"))
                .arg(out_dir.join("harness.c"))
                .arg(&lib)
                .args(STATICLIB_SYSTEM_LIBS)
                .arg("-o")
                .arg(&exe),
            "linking the docs/ecu.md example",
        );
        let out = Command::new(&exe).output().expect("run the example");
        let stdout = String::from_utf8_lossy(&out.stdout);
        if corrupt {
            assert_eq!(out.status.code(), Some(10), "corrupt blob: {stdout}");
            assert!(stdout.contains("CRC"), "the failure is logged: {stdout}");
        } else {
            assert_eq!(out.status.code(), Some(0), "example run: {stdout}");
        }
    }
}
