//! Quantisation (int8 vs float agreement through the core), checkpoints, export -> decode -> score
//! round trips and blob inspection.
use riskscore_data::events::EventKind;
use riskscore_data::events::{Frame, Sequence};
use riskscore_train::export::{self, Checkpoint, CheckpointModel, DrlFormat};
use riskscore_train::quantize;
use riskscore_train::train::{self, Progress, TrainConfig};
use scorer_core::model::{decode, Model};
use scorer_core::VehicleState;

fn car(x: f32, y: f32, vx: f32, vy: f32, length: f32) -> VehicleState {
    let v = (vx * vx + vy * vy).sqrt().max(1e-3);
    VehicleState {
        x,
        y,
        vx,
        vy,
        hx: vx / v,
        hy: vy / v,
        acc: 0.0,
        length,
        width: 1.8,
    }
}

/// Mixed geometry: rear-end approaches, crossing paths and safe following.
fn dataset(n: usize) -> Vec<Sequence> {
    let mut out = Vec::new();
    for i in 0..n {
        let t_impact = 6.0f64;
        let closing = 4.0 + (i % 7) as f32;
        let v = 10.0 + (i % 5) as f32 * 2.0;
        let crossing = i % 3 == 0;
        let mut c = Sequence::new(format!("c{i}"), EventKind::Crash, Some(t_impact));
        let mut s = Sequence::new(format!("s{i}"), EventKind::Safe, None);
        for k in 15..=65 {
            let t = k as f64 * 0.1;
            let tt = (t_impact - t) as f32;
            let x_e = v * t as f32;
            let partner = if crossing {
                // Partner crosses from the right, reaching the conflict point with the ego.
                let xc = v * t_impact as f32 + 3.5;
                car(xc, -3.0 - closing * tt, 0.0, closing, 4.8)
            } else {
                car(
                    x_e + 4.5 + closing * tt,
                    0.3,
                    v - closing,
                    0.0,
                    4.5 + (i % 3) as f32,
                )
            };
            c.frames.push(Frame {
                time: t,
                ego: car(x_e, 0.0, v, 0.0, 4.5),
                partner,
            });
            s.frames.push(Frame {
                time: t,
                ego: car(x_e, 0.0, v, 0.0, 4.5),
                partner: car(
                    x_e + 30.0 + (i % 4) as f32 * 5.0,
                    3.5 * (i % 2) as f32,
                    v,
                    0.0,
                    4.5,
                ),
            });
        }
        out.push(c);
        out.push(s);
    }
    out
}

fn config() -> TrainConfig {
    let mut c = TrainConfig::default();
    c.comparisons.temporal.pairs = 600;
    c.comparisons.cross_sequence.pairs = 600;
    c.comparisons.physics.pairs = 300;
    c.optimiser.max_epochs = 12;
    c
}

fn trained() -> (Vec<Sequence>, train::TrainedDrl, train::TrainedMsra) {
    let seqs = dataset(18);
    let cfg = config();
    let prepared = train::prepare_comparisons(&seqs, None, &cfg);
    let drl = train::train_drl(&seqs, &prepared, &cfg, Progress::Hidden).unwrap();
    let msra = train::train_msra(&seqs, &prepared, &cfg, Progress::Hidden).unwrap();
    (seqs, drl, msra)
}

#[test]
fn int8_network_agrees_with_float_and_round_trips_through_the_blob() {
    let (seqs, drl, msra) = trained();
    let obs = train::calibration_observations(&seqs, 100_000);
    let q = quantize::quantize(&drl.params, &drl.calibration).unwrap();
    let agreement = quantize::verify(&drl.params, &q, &obs).unwrap();
    assert!(agreement.correlation > 0.995, "{agreement:?}");
    assert!(
        agreement.mean_abs_error < 0.05 * agreement.float_std.max(1e-3),
        "{agreement:?}"
    );
    // The quantiser used the core's own multipliers: every hidden pair is canonical.
    for l in &q.layers[..q.layers.len() - 1] {
        for (m, s) in l.multipliers.chunks_exact(4).zip(&l.shifts) {
            let m = i32::from_le_bytes(m.try_into().unwrap());
            assert!(scorer_core::quant::is_valid_multiplier(m, *s as i8));
        }
    }
    // Export -> decode -> score is bit-identical to the in-memory core network.
    let ck = Checkpoint::new(
        CheckpointModel::Drl {
            params: drl.params.clone(),
            calibration: drl.calibration.clone(),
        },
        serde_json::json!({"test": true}),
    );
    let blob = export::export(&ck, DrlFormat::Int8).unwrap();
    let decoded = decode(&blob).unwrap();
    assert!(matches!(decoded, Model::DrlInt8(_)));
    let core = q.as_core().unwrap();
    for s in seqs.iter().take(6) {
        for (e, p) in s.frames.iter().map(|f| (&f.ego, &f.partner)) {
            let f = scorer_core::drl_inputs(e, p);
            assert_eq!(decoded.score(e, p).to_bits(), core.forward(&f)[0].to_bits());
        }
    }
    // MSRA blob: the core reproduces the candle model's scores.
    let mblob = export::msra_blob(&msra.params).unwrap();
    let m = decode(&mblob).unwrap();
    assert!(matches!(m, Model::Msra(_)));
    for s in seqs.iter().take(4) {
        for (e, p) in s.frames.iter().map(|f| (&f.ego, &f.partner)) {
            let v = m.score(e, p);
            assert!(v.is_finite());
        }
    }
}

/// One safe event, its partner followed at a constant gap and speed (`riskctl train` on a folder
/// of that one event): every DRL input is constant, so the calibrated input range was f32
/// round-off (±2.4e-7) and the export failed with `the network does not fit the core:
/// NonFinite { field: "input_add", index: 0 }`. It now quantises, exports and scores like the
/// float network.
#[test]
fn a_network_trained_on_constant_inputs_quantises_and_exports() {
    let mut s = Sequence::new("s4", EventKind::Safe, None);
    for k in 0..60 {
        let t = k as f64 * 0.1;
        let x = 14.0 * t as f32;
        s.frames.push(Frame {
            time: t,
            ego: car(x, 0.0, 14.0, 0.0, 4.5),
            partner: car(x + 34.5, 0.0, 14.0, 0.0, 4.5),
        });
    }
    let seqs = vec![s];
    let cfg = TrainConfig::default();
    let prepared = train::prepare_comparisons(&seqs, None, &cfg);
    let drl = train::train_drl(&seqs, &prepared, &cfg, Progress::Hidden).unwrap();
    let span = drl.calibration.input.max - drl.calibration.input.min;
    assert!(span < quantize::MIN_INPUT_SPAN, "not the case: {span}");
    let q = quantize::quantize(&drl.params, &drl.calibration).unwrap();
    let ck = Checkpoint::new(
        CheckpointModel::Drl {
            params: drl.params.clone(),
            calibration: drl.calibration.clone(),
        },
        serde_json::json!({"test": true}),
    );
    let (int8_blob, f32_blob) = (
        export::export(&ck, DrlFormat::Int8).unwrap(),
        export::export(&ck, DrlFormat::F32).unwrap(),
    );
    let (decoded, float) = (decode(&int8_blob).unwrap(), decode(&f32_blob).unwrap());
    let obs = train::calibration_observations(&seqs, usize::MAX);
    let agreement = quantize::verify(&drl.params, &q, &obs).unwrap();
    assert!(agreement.max_abs_error < 0.05, "{agreement:?}");
    for f in &seqs[0].frames {
        let (int8, f32) = (
            decoded.score(&f.ego, &f.partner),
            float.score(&f.ego, &f.partner),
        );
        assert!(
            int8.is_finite() && (int8 - f32).abs() < 0.05,
            "{int8} vs {f32}"
        );
    }
}

#[test]
fn conflicts_outscore_safe_frames_in_the_deployed_int8_path() {
    let (seqs, drl, _) = trained();
    let q = quantize::quantize(&drl.params, &drl.calibration).unwrap();
    let core = q.as_core().unwrap();
    let max_score = |s: &Sequence| {
        s.alert_frames()
            .iter()
            .map(|f| core.forward(&scorer_core::drl_inputs(&f.ego, &f.partner))[0])
            .fold(f32::MIN, f32::max)
    };
    let conflict_min = seqs
        .iter()
        .filter(|s| s.is_conflict())
        .map(max_score)
        .fold(f32::MAX, f32::min);
    let safe_max = seqs
        .iter()
        .filter(|s| !s.is_conflict())
        .map(max_score)
        .fold(f32::MIN, f32::max);
    assert!(conflict_min > safe_max, "{conflict_min} <= {safe_max}");
}

#[test]
fn checkpoints_round_trip_and_bad_files_are_named() {
    let (_, drl, msra) = trained();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("drl.json");
    let ck = Checkpoint::new(
        CheckpointModel::Drl {
            params: drl.params.clone(),
            calibration: drl.calibration.clone(),
        },
        serde_json::Value::Null,
    );
    ck.save(&path).unwrap();
    assert_eq!(Checkpoint::load(&path).unwrap(), ck);
    let mpath = dir.path().join("msra.json");
    let mck = Checkpoint::new(
        CheckpointModel::Msra {
            params: msra.params.clone(),
        },
        serde_json::Value::Null,
    );
    mck.save(&mpath).unwrap();
    assert_eq!(Checkpoint::load(&mpath).unwrap(), mck);
    // f32 export of the same checkpoint decodes as DRL-f32.
    let f32_blob = export::export(&ck, DrlFormat::F32).unwrap();
    assert!(matches!(decode(&f32_blob).unwrap(), Model::DrlF32(_)));

    // Saved again by a Windows editor, with a UTF-8 byte-order mark: 'line 1, column 1:
    // expected value' before, the same checkpoint now.
    let bom = dir.path().join("bom.json");
    let mut bytes = "\u{feff}".as_bytes().to_vec();
    bytes.extend(std::fs::read(&path).unwrap());
    std::fs::write(&bom, bytes).unwrap();
    assert_eq!(Checkpoint::load(&bom).unwrap(), ck);

    let bad = dir.path().join("bad.json");
    std::fs::write(
        &bad,
        "{\"format\": \"riskscore-checkpoint\",\n \"version\": 1, \"model\": {\"kind\": \"drl\"}}",
    )
    .unwrap();
    let err = Checkpoint::load(&bad).unwrap_err().to_string();
    assert!(err.contains("bad.json") && err.contains("line 2"), "{err}");
}

/// A checkpoint that does not parse (a field removed, the file cut short) is named with its file,
/// the parse error's line and column, and the field, each once: the position used to be named
/// twice (`line 17, column 3: missing field `w` at line 17 column 3`).
#[test]
fn checkpoint_parse_errors_name_the_position_once() {
    use riskscore_train::train::msra::{MsraParams, MsraTermParams};
    let dir = tempfile::tempdir().unwrap();
    let ck = Checkpoint::new(
        CheckpointModel::Msra {
            params: MsraParams {
                terms: vec![MsraTermParams {
                    surrogate: "ttc2d".into(),
                    lo: 0.0,
                    hi: 10.0,
                    w: 1.0,
                    a: 1.0,
                    b: 0.0,
                }],
            },
        },
        serde_json::Value::Null,
    );
    let mut value = serde_json::to_value(&ck).unwrap();
    value["model"]["params"]["terms"][0]
        .as_object_mut()
        .unwrap()
        .remove("w")
        .unwrap();
    // On one line; named at the start of the term that lacks `w` (it was where the model closes,
    // `text.find("}]}}") + 4`: serde read the model, a tagged enum, whole).
    let text = serde_json::to_string(&value).unwrap();
    let column = text.find("[{").unwrap() + 2;
    let missing = dir.path().join("missing.json");
    std::fs::write(&missing, &text).unwrap();
    let err = Checkpoint::load(&missing).unwrap_err().to_string();
    assert_eq!(
        err,
        format!(
            "{}: not a riskscore checkpoint: line 1, column {column}: `model.params.terms[0]` \
             (the object that starts there) is missing field `w`",
            missing.display()
        )
    );

    // Cut short inside a string on the second line: EOF at its end, its 27th character.
    let cut = dir.path().join("cut.json");
    std::fs::write(&cut, "{\n  \"format\": \"riskscore-chec").unwrap();
    let err = Checkpoint::load(&cut).unwrap_err().to_string();
    assert_eq!(
        err,
        format!(
            "{}: not a riskscore checkpoint: line 2, column 27: EOF while parsing a string",
            cut.display()
        )
    );
}

/// Line and column (1-based, the column counted in bytes as serde_json counts it) of byte
/// `offset` of `text`.
fn line_column(text: &str, offset: usize) -> (usize, usize) {
    let before = &text[..offset];
    let line = before.matches('\n').count() + 1;
    let column = offset - before.rfind('\n').map_or(0, |i| i + 1) + 1;
    (line, column)
}

/// An MSRA checkpoint of two terms, TTC2D and TAdv, as JSON.
fn two_term_msra() -> serde_json::Value {
    use riskscore_train::train::msra::{MsraParams, MsraTermParams};
    let term = |surrogate: &str| MsraTermParams {
        surrogate: surrogate.into(),
        lo: 0.0,
        hi: 10.0,
        w: 1.0,
        a: 1.0,
        b: 0.0,
    };
    let ck = Checkpoint::new(
        CheckpointModel::Msra {
            params: MsraParams {
                terms: vec![term("ttc2d"), term("tadv")],
            },
        },
        serde_json::Value::Null,
    );
    serde_json::to_value(&ck).unwrap()
}

/// `text` written to `dir/name`, loaded; the error's text with the file's name dropped.
fn load_error(dir: &std::path::Path, name: &str, text: &str) -> String {
    let path = dir.join(name);
    std::fs::write(&path, text).unwrap();
    let err = Checkpoint::load(&path).unwrap_err().to_string();
    let prefix = format!("{}: not a riskscore checkpoint: ", path.display());
    err.strip_prefix(&prefix)
        .unwrap_or_else(|| panic!("{err}"))
        .to_string()
}

/// A value of the wrong type inside the model (a string for a number, edited by hand) names the
/// path of its field and the value's own position: it was serde's bare
/// `invalid type: string "x", expected f32` at the position where the model closes.
#[test]
fn checkpoint_type_errors_name_the_field_path() {
    let dir = tempfile::tempdir().unwrap();
    let mut msra = two_term_msra();
    msra["model"]["params"]["terms"][1]["w"] = serde_json::json!("x");
    let (_, drl, _) = trained();
    let drl = Checkpoint::new(
        CheckpointModel::Drl {
            params: drl.params.clone(),
            calibration: drl.calibration.clone(),
        },
        serde_json::Value::Null,
    );
    let mut weight = serde_json::to_value(&drl).unwrap();
    weight["model"]["params"]["layers"][1]["weight"][3] = serde_json::json!("x");
    let mut observations = serde_json::to_value(&drl).unwrap();
    observations["model"]["calibration"]["observations"] = serde_json::json!(-1);
    // Each bad value is the first `bad` after `after` in the file.
    let cases = [
        (
            &msra,
            "\"x\"",
            "\"x\"",
            "`model.params.terms[1].w`: invalid type: string \"x\", expected f32",
        ),
        (
            &weight,
            "\"x\"",
            "\"x\"",
            "`model.params.layers[1].weight[3]`: invalid type: string \"x\", expected f32",
        ),
        (
            &observations,
            "\"observations\"",
            "-1",
            "`model.calibration.observations`: invalid value: integer `-1`, expected usize",
        ),
    ];
    for (value, after, bad, what) in cases {
        // On one line and pretty, over many lines (as `riskctl train` writes a checkpoint).
        for text in [
            serde_json::to_string(value).unwrap(),
            serde_json::to_string_pretty(value).unwrap(),
        ] {
            let field = text.find(after).unwrap();
            // serde_json names the value's last character.
            let end = field + text[field..].find(bad).unwrap() + bad.len() - 1;
            let (line, column) = line_column(&text, end);
            assert_eq!(
                load_error(dir.path(), "typed.json", &text),
                format!("line {line}, column {column}: {what}")
            );
        }
    }
}

/// A missing field is named with the object that lacks it and where that object starts (it was
/// named at the end of the model, the object serde read whole, wherever the field was missing),
/// the position named once.
#[test]
fn checkpoint_missing_fields_name_the_object_that_lacks_them() {
    let dir = tempfile::tempdir().unwrap();
    let mut term = two_term_msra();
    term["model"]["params"]["terms"][1]
        .as_object_mut()
        .unwrap()
        .remove("w")
        .unwrap();
    let mut params = two_term_msra();
    params["model"].as_object_mut().unwrap().remove("params");
    let mut version = two_term_msra();
    version.as_object_mut().unwrap().remove("version");
    for text in [
        serde_json::to_string_pretty(&term).unwrap(),
        serde_json::to_string(&term).unwrap(),
    ] {
        let start = text[..text.find("\"tadv\"").unwrap()].rfind('{').unwrap();
        let (line, column) = line_column(&text, start);
        let err = load_error(dir.path(), "term.json", &text);
        assert_eq!(
            err,
            format!(
                "line {line}, column {column}: `model.params.terms[1]` (the object that starts \
                 there) is missing field `w`"
            )
        );
        assert_eq!(err.matches("line ").count(), 1, "{err}");
    }
    let text = serde_json::to_string_pretty(&params).unwrap();
    let start = text.find("\"model\": {").unwrap() + "\"model\": ".len();
    let (line, column) = line_column(&text, start);
    assert!(line > 1, "{text}");
    assert_eq!(
        load_error(dir.path(), "params.json", &text),
        format!(
            "line {line}, column {column}: `model` (the object that starts there) is missing \
             field `params`"
        )
    );
    let text = serde_json::to_string_pretty(&version).unwrap();
    assert_eq!(
        load_error(dir.path(), "version.json", &text),
        "line 1, column 1: the checkpoint (the object that starts there) is missing field \
         `version`"
    );
}

/// The checkpoint reader reads the model in a second step (so that its errors name the field);
/// every checkpoint the derived one-step reader (`serde_json::from_str::<Checkpoint>`) reads
/// reads to the same values: as `riskctl train` writes it, on one line, with the `kind` after
/// the fields, with fields it does not know, and with the model in the sequence form serde also
/// reads (`["msra", {"terms": ..}]`).
#[test]
fn checkpoints_read_in_two_steps_as_in_one() {
    let (_, drl, msra) = trained();
    let dir = tempfile::tempdir().unwrap();
    let drl = Checkpoint::new(
        CheckpointModel::Drl {
            params: drl.params.clone(),
            calibration: drl.calibration.clone(),
        },
        serde_json::json!({"seed": 7, "data": "events/"}),
    );
    let msra = Checkpoint::new(
        CheckpointModel::Msra {
            params: msra.params.clone(),
        },
        serde_json::Value::Null,
    );
    let json = |v: &serde_json::Value| serde_json::to_string(v).unwrap();
    let mut texts = Vec::new();
    for (ck, kind) in [(&drl, "drl"), (&msra, "msra")] {
        texts
            .push(String::from_utf8(ck.to_json(std::path::Path::new("ck.json")).unwrap()).unwrap());
        let value = serde_json::to_value(ck).unwrap();
        texts.push(json(&value));
        let mut fields = value["model"].as_object().unwrap().clone();
        fields.remove("kind");
        let rest: Vec<String> = fields
            .iter()
            .map(|(k, v)| format!("{}:{}", json(&k.as_str().into()), json(v)))
            .collect();
        let top = |model: String| {
            format!(
                "{{\"format\":\"riskscore-checkpoint\",\"version\":3,\"model\":{model},\"meta\":{}}}",
                json(&value["meta"])
            )
        };
        // The tag last, and a field neither reader knows, in the model and beside it.
        texts.push(top(format!("{{{},\"kind\":\"{kind}\"}}", rest.join(","))));
        texts.push(
            top(format!(
                "{{\"note\":[1,{{\"kind\":\"x\"}}],{},\"kind\":\"{kind}\"}}",
                rest.join(",")
            ))
            .replacen('{', "{\"extra\":{\"model\":0},", 1),
        );
        // The sequence form: the tag, then the fields in their order.
        let seq = match ck.model {
            CheckpointModel::Drl { .. } => format!(
                "[\"drl\",{},{}]",
                json(&value["model"]["params"]),
                json(&value["model"]["calibration"])
            ),
            CheckpointModel::Msra { .. } => {
                format!("[\"msra\",{}]", json(&value["model"]["params"]))
            }
        };
        texts.push(top(seq));
    }
    for (i, text) in texts.iter().enumerate() {
        let one_step: Checkpoint =
            serde_json::from_str(text).unwrap_or_else(|e| panic!("{e}: {text}"));
        let path = dir.path().join(format!("{i}.json"));
        std::fs::write(&path, text).unwrap();
        let two_steps = Checkpoint::load(&path).unwrap_or_else(|e| panic!("{e}: {text}"));
        assert_eq!(two_steps, one_step, "{text}");
        let original = if one_step.kind_name() == "drl" {
            &drl
        } else {
            &msra
        };
        assert_eq!(&two_steps, original, "{text}");
    }
}

/// A checkpoint cut or edited by another tool: a short weight array used to panic in the
/// quantiser (`range end index 416 out of range for slice of length 415`), and a weight beyond
/// f32's range (JSON `1e39`, read as infinity) gave an int8 blob that passed every check. Both are
/// refused at load, naming the field.
#[test]
fn malformed_checkpoint_parameters_are_refused_naming_the_field() {
    let (_, drl, msra) = trained();
    let dir = tempfile::tempdir().unwrap();
    let ck = Checkpoint::new(
        CheckpointModel::Drl {
            params: drl.params.clone(),
            calibration: drl.calibration.clone(),
        },
        serde_json::Value::Null,
    );
    let mck = Checkpoint::new(
        CheckpointModel::Msra {
            params: msra.params.clone(),
        },
        serde_json::Value::Null,
    );
    let json = |c: &Checkpoint| serde_json::to_value(c).unwrap();
    let cases: Vec<(&str, serde_json::Value, &str)> = vec![
        (
            "short",
            {
                let mut v = json(&ck);
                v["model"]["params"]["layers"][0]["weight"]
                    .as_array_mut()
                    .unwrap()
                    .pop();
                v
            },
            "`model.params.layers[0].weight` has",
        ),
        (
            "inf-weight",
            {
                let mut v = json(&ck);
                v["model"]["params"]["layers"][1]["weight"][3] = serde_json::json!(1e39);
                v
            },
            "`model.params.layers[1].weight[3]` is inf",
        ),
        (
            "scaler",
            {
                let mut v = json(&ck);
                v["model"]["params"]["scaler"]["std"]
                    .as_array_mut()
                    .unwrap()
                    .pop();
                v
            },
            "`model.params.scaler.std` has",
        ),
        (
            "calibration",
            {
                let mut v = json(&ck);
                v["model"]["calibration"]["input"] = serde_json::json!({"min": 5.0, "max": -5.0});
                v
            },
            "`model.calibration.input` is [5, -5]",
        ),
        (
            "msra",
            {
                let mut v = json(&mck);
                v["model"]["params"]["terms"][0]["a"] = serde_json::json!(-1e39);
                v
            },
            "`model.params.terms[0].a` is -inf",
        ),
    ];
    for (name, value, expected) in cases {
        let path = dir.path().join(format!("{name}.json"));
        std::fs::write(&path, serde_json::to_vec(&value).unwrap()).unwrap();
        let err = Checkpoint::load(&path)
            .map(|_| "loaded".to_string())
            .unwrap_or_else(|e| e.to_string());
        assert!(
            err.contains(&format!("{name}.json: not a riskscore checkpoint"))
                && err.contains(expected),
            "{name}: {err}"
        );
    }
}

#[test]
fn inspect_reports_structure_and_detects_corruption() {
    let (_, drl, msra) = trained();
    let q = quantize::quantize(&drl.params, &drl.calibration).unwrap();
    let blob = export::drl_int8_blob(&q).unwrap();
    let text = export::inspect(&blob).unwrap();
    assert!(text.contains("drl-int8"), "{text}");
    assert!(text.contains("13-32-16-1"), "{text}");
    assert!(text.contains("integrity"), "{text}");
    let mut corrupt = blob.clone();
    let last = corrupt.len() - 1;
    corrupt[last] ^= 0x55;
    let err = export::inspect(&corrupt).unwrap_err();
    assert!(
        matches!(err, scorer_core::model::ModelError::CrcMismatch { .. }),
        "{err:?}"
    );
    let mtext = export::inspect(&export::msra_blob(&msra.params).unwrap()).unwrap();
    assert!(
        mtext.contains("msra") && mtext.contains("TAdv") && mtext.contains("EI"),
        "{mtext}"
    );
}
