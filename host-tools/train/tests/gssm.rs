//! GSSM, SSRA and MSRA-with-GSSM: likelihood fit recovering a known lognormal relation, the candle
//! CDF against the core's, SSRA alignment improving the pairwise objective, export -> decode ->
//! score parity, the MSRA+GSSM blob round trip, and shipping the three models end to end from a
//! tiny simulated folder.
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use riskscore_data::events::{load_prepared, PrepareConfig};
use riskscore_data::events::{EventKind, Frame, Sequence};
use riskscore_eval::scoring::model_row_name;
use riskscore_train::comparisons::{ObservationTable, RowOrigin};
use riskscore_train::gssm::config::{FitConfig, SsraConfig, SsraScore};
use riskscore_train::gssm::fit::{fit_gssm_on_observations, nll};
use riskscore_train::gssm::msra::parse_configuration;
use riskscore_train::gssm::net::{GssmNet, GssmParams};
use riskscore_train::gssm::ship::{ship, SHIPPED_FILES};
use riskscore_train::gssm::ssra::{set_objective, Ssra};
use riskscore_train::gssm::{align_msra_gssm, align_ssra, GssmConfig};
use riskscore_train::train::{self, Progress, TrainConfig};
use scorer_core::gssm::{GssmScore, S_INDEX};
use scorer_core::model::OutsidePolicy;
use scorer_core::msra::MsraTerm;
use scorer_core::{Features, Model, SurrogateKind, Surrogates, FEATURE_COUNT};

mod common;
use common::{car, conflict};

/// Safe following: the gap grows with speed (about 1.5 s headway plus 8 m), with slow oscillation.
fn safe(id: usize) -> Sequence {
    let v = 8.0 + (id % 11) as f32 * 1.5;
    let gap = 8.0 + 1.5 * v;
    let mut s = Sequence::new(format!("s{id}"), EventKind::Safe, None);
    for k in 0..40 {
        let t = k as f64 * 0.1;
        let x_e = v * t as f32;
        let g = gap * (1.0 + 0.1 * (t as f32 + id as f32).sin());
        s.frames.push(Frame {
            time: t,
            ego: car(x_e, 0.0, v),
            partner: car(x_e + 4.5 + g, 0.0, v),
        });
    }
    s
}

fn dataset(n: usize) -> Vec<Sequence> {
    (0..n)
        .flat_map(|i| [conflict(i, 4.0 + (i % 8) as f32, 0.0), safe(i)])
        .collect()
}

fn small_train_config() -> TrainConfig {
    let mut c = TrainConfig::default();
    c.comparisons.temporal.pairs = 400;
    c.comparisons.cross_sequence.pairs = 400;
    c.comparisons.physics.pairs = 200;
    c.optimiser.max_epochs = 10;
    c.optimiser.batch_pairs = 256;
    c.optimiser.validation_fraction = 0.0;
    c
}

fn small_fit() -> FitConfig {
    FitConfig {
        hidden: vec![16],
        max_epochs: 60,
        batch: 256,
        learning_rate: 1e-2,
        ..FitConfig::default()
    }
}

/// Synthetic context: feature 3 (ego speed) uniform in [5, 25], features 0 and 1 irrelevant noise,
/// the others constant; `ln s ~ N(1.5 + 0.08 v, 0.3^2)`.
fn synthetic(n: usize, seed: u64) -> Vec<Features> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let noise = Normal::new(0.0f32, 0.3).unwrap();
    (0..n)
        .map(|_| {
            let mut f = [0f32; FEATURE_COUNT];
            f[0] = rng.random_range(4.0..6.0);
            f[1] = rng.random_range(4.0..12.0);
            let v: f32 = rng.random_range(5.0..25.0);
            f[3] = v;
            f[S_INDEX] = (1.5 + 0.08 * v + noise.sample(&mut rng)).exp();
            f
        })
        .collect()
}

fn decode_gssm(blob: &[u8]) -> scorer_core::GssmModel<'_> {
    match scorer_core::model::decode(blob).unwrap() {
        Model::Gssm(g) => g,
        other => panic!("expected a GSSM model, got {:?}", other.kind()),
    }
}

#[test]
fn nll_fit_decreases_and_recovers_a_known_lognormal_relation() {
    let obs = synthetic(3000, 1);
    let val = synthetic(600, 2);
    let cfg = FitConfig {
        smoothness: 0.05,
        ..small_fit()
    };
    let g = fit_gssm_on_observations(&obs, &val, &cfg, 7, Progress::Hidden).unwrap();
    let first = g.report.history.first().unwrap().2.unwrap();
    let best = g.report.validation_nll.unwrap();
    assert!(best < first - 0.05, "validation NLL {first} -> {best}");
    // The optimum is the Gaussian entropy 1/2 ln(2 pi e 0.09) = 0.2149 nats.
    assert!((best - 0.2149).abs() < 0.08, "validation NLL {best}");
    assert!(nll(&g.params, &val).unwrap() <= first);
    // The core's view of the exported network recovers mu(v) and sigma.
    let blob = g.params.gssm_blob(GssmScore::Intensity).unwrap();
    let core = decode_gssm(&blob);
    for v in [8.0f32, 15.0, 22.0] {
        let mut f = [0f32; FEATURE_COUNT];
        f[0] = 5.0;
        f[1] = 8.0;
        f[3] = v;
        let (mu, lv) = core.params(&f);
        let sigma = (0.5 * lv).exp();
        eprintln!(
            "v {v}: mu {mu} sigma {sigma} hist {:?}",
            g.report.history.last()
        );
        assert!((mu - (1.5 + 0.08 * v)).abs() < 0.1, "v {v}: mu {mu}");
        assert!((sigma - 0.3).abs() < 0.06, "v {v}: sigma {sigma}");
    }
}

#[test]
fn candle_survival_matches_the_core_within_1e_5() {
    let scaler = riskscore_train::gssm::fit::scaler_of(&synthetic(200, 3));
    let net = GssmNet::new(scaler, &[12, 8], 11, 2.5, -1.0).unwrap();
    let params = net.params().unwrap();
    let mut feats = synthetic(400, 4);
    // Guards: contact, no spacing, a NaN context feature, extreme spacings.
    let edge = [0.0f32, -1.0, f32::INFINITY, f32::NAN, 1e-3, 1e4];
    for (i, s) in edge.iter().enumerate() {
        feats[i][S_INDEX] = *s;
    }
    feats[10][5] = f32::NAN;
    let rows = net.rows_tensor(&feats).unwrap();
    let f_candle = net.survival(&rows).unwrap().to_vec1::<f32>().unwrap();
    let logit_candle = net
        .deployed_score(&rows, GssmScore::Logit)
        .unwrap()
        .to_vec1::<f32>()
        .unwrap();
    let train_candle = net
        .score(&rows, SsraScore::Logit)
        .unwrap()
        .to_vec1::<f32>()
        .unwrap();
    let intensity_candle = net
        .deployed_score(&rows, GssmScore::Intensity)
        .unwrap()
        .to_vec1::<f32>()
        .unwrap();
    let blob = params.gssm_blob(GssmScore::Cdf).unwrap();
    let core = decode_gssm(&blob);
    let (mut lo, mut hi) = (1.0f32, 0.0f32);
    for (i, f) in feats.iter().enumerate() {
        let fc = core.survival(f);
        assert!(
            (fc - f_candle[i]).abs() <= 1e-5,
            "row {i}: core {fc}, candle {}",
            f_candle[i]
        );
        lo = lo.min(fc);
        hi = hi.max(fc);
        // The core's f32 `ln(1 - 1e-6)` at the clip carries ~0.1 % error; elsewhere they agree.
        let ic = scorer_core::gssm::intensity(fc);
        let tol = if (1e-3..=1.0 - 1e-3).contains(&fc) {
            1e-3
        } else {
            1e-2
        };
        assert!(
            (ic - intensity_candle[i]).abs() < tol,
            "row {i}: {ic} vs {}",
            intensity_candle[i]
        );
        // The logit is steep near the clip; compare where F is well inside (0, 1).
        if (1e-3..=1.0 - 1e-3).contains(&fc) {
            let lc = scorer_core::gssm::logit(fc);
            assert!(
                (lc - logit_candle[i]).abs() < 2e-3,
                "row {i}: {lc} vs {}",
                logit_candle[i]
            );
            // The training score is the log-compressed logit.
            let soft = riskscore_train::gssm::net::compress_scalar(f64::from(lc)) as f32;
            assert!(
                (soft - train_candle[i]).abs() < 2e-3,
                "row {i}: {soft} vs {}",
                train_candle[i]
            );
        }
    }
    assert_eq!(core.survival(&feats[0]), 1.0);
    assert_eq!(f_candle[0], 1.0);
    assert_eq!(f_candle[2], 0.0);
    assert_eq!(f_candle[3], 0.0);
    assert!(
        hi - lo > 0.5,
        "the test must cover a range of F_S: [{lo}, {hi}]"
    );
}

#[test]
fn ssra_fine_tuning_changes_parameters_and_improves_the_pairwise_objective() {
    let data = dataset(24);
    let cfg = small_train_config();
    let safe_obs = riskscore_train::gssm::fit::safe_observations(&data);
    // A briefly fitted GSSM: a sensible distribution that does not yet order the pairs well.
    let brief = FitConfig {
        max_epochs: 2,
        learning_rate: 1e-3,
        ..small_fit()
    };
    let g = fit_gssm_on_observations(&safe_obs, &[], &brief, 3, Progress::Hidden).unwrap();
    let prepared = train::prepare_comparisons(&data, None, &cfg);
    let before_model = Ssra::new(&g.params, SsraScore::Logit).unwrap();
    let before = set_objective(
        &before_model,
        &prepared.fit,
        &SsraConfig::default().objective(),
    )
    .unwrap();
    let ssra_cfg = SsraConfig {
        learning_rate: 1e-2,
        max_epochs: 10,
        ..SsraConfig::default()
    };
    let s = align_ssra(&g.params, &prepared, &cfg, &ssra_cfg, Progress::Hidden).unwrap();
    assert!(!s.kept_initial);
    assert_ne!(
        s.params.layers, g.params.layers,
        "fine-tuning must move the parameters"
    );
    assert_eq!(
        s.params.parameter_count(),
        g.params.parameter_count(),
        "no new parameters"
    );
    let after_model = Ssra::new(&s.params, SsraScore::Logit).unwrap();
    let after = set_objective(&after_model, &prepared.fit, &ssra_cfg.objective()).unwrap();
    assert!(
        after.pair < 0.8 * before.pair && after.total < before.total,
        "pair loss {} -> {}, total {} -> {}",
        before.pair,
        after.pair,
        before.total,
        after.total
    );
    // The exported blob is the GSSM kind with the SSRA score mode, named SSRA.
    let blob = s.blob().unwrap();
    let m = scorer_core::model::decode(&blob).unwrap();
    assert_eq!(model_row_name(&m), "SSRA");
}

#[test]
fn export_decode_score_equals_the_candle_forward() {
    let data = dataset(10);
    let g = fit_gssm_on_observations(
        &riskscore_train::gssm::fit::safe_observations(&data),
        &[],
        &FitConfig {
            max_epochs: 5,
            ..small_fit()
        },
        5,
        Progress::Hidden,
    )
    .unwrap();
    let mut table = ObservationTable::default();
    let mut pairs = Vec::new();
    for s in &data {
        for (e, p) in s.frames.iter().map(|f| (&f.ego, &f.partner)).step_by(3) {
            table.push(e, p, RowOrigin::External);
            pairs.push((*e, *p));
        }
    }
    let ssra = Ssra::new(&g.params, SsraScore::Logit).unwrap();
    let blob = g.params.gssm_blob(GssmScore::Logit).unwrap();
    let model = scorer_core::model::decode(&blob).unwrap();
    let intensity_blob = g.params.gssm_blob(GssmScore::Intensity).unwrap();
    let intensity_model = scorer_core::model::decode(&intensity_blob).unwrap();
    assert_eq!(model_row_name(&intensity_model), "GSSM");
    let rows = ssra.net().rows_tensor(&table.features).unwrap();
    let candle = ssra
        .net()
        .deployed_score(&rows, GssmScore::Logit)
        .unwrap()
        .to_vec1::<f32>()
        .unwrap();
    let f_candle = ssra
        .net()
        .deployed_score(&rows, GssmScore::Intensity)
        .unwrap()
        .to_vec1::<f32>()
        .unwrap();
    let mut checked = 0;
    for (i, (e, p)) in pairs.iter().enumerate() {
        let deployed = model.score(e, p);
        let tol = 1e-3 * (1.0 + deployed.abs());
        assert!(
            (deployed - candle[i]).abs() <= tol,
            "row {i}: core {deployed}, candle {}",
            candle[i]
        );
        let intensity = intensity_model.score(e, p);
        let expected = f_candle[i];
        // f32 `ln(1 - 1e-6)` in the core: ~0.1 % at the clip.
        assert!(
            (intensity - expected).abs() <= 1e-2,
            "row {i}: {intensity} vs {expected}"
        );
        checked += 1;
    }
    assert!(checked > 100);
}

#[test]
fn msra_with_gssm_trains_and_round_trips_through_the_blob() {
    let data = dataset(16);
    let cfg = small_train_config();
    let g = fit_gssm_on_observations(
        &riskscore_train::gssm::fit::safe_observations(&data),
        &[],
        &small_fit(),
        9,
        Progress::Hidden,
    )
    .unwrap();
    let prepared = train::prepare_comparisons(&data, None, &cfg);
    let kinds = parse_configuration("tadv+ei+gssm").unwrap();
    assert_eq!(
        kinds,
        [SurrogateKind::Tadv, SurrogateKind::Ei, SurrogateKind::Gssm]
    );
    assert!(parse_configuration("ei+ei").is_err());
    assert!(parse_configuration("ei+foo").is_err());
    let m = align_msra_gssm(
        &kinds,
        &g.params,
        &data,
        &prepared,
        &cfg,
        3e-2,
        Progress::Hidden,
    )
    .unwrap();
    let weights = m.params.weights();
    assert_eq!(weights.len(), 3);
    let share: f32 = weights.iter().map(|w| w.share.abs()).sum();
    assert!((share - 1.0).abs() < 1e-4, "shares sum to {share}");
    let blob = m.params.blob().unwrap();
    let decoded = scorer_core::model::decode(&blob).unwrap();
    let Model::Msra(core) = &decoded else {
        panic!("expected MSRA, got {:?}", decoded.kind())
    };
    assert!(core.gssm.is_some());
    assert_eq!(core.terms.iter().map(|t| t.kind).collect::<Vec<_>>(), kinds);
    // Deployed scores equal the float model's (same terms, same embedded network).
    let (embedded, mode) = GssmParams::from_blob(&blob).unwrap();
    assert_eq!(mode, GssmScore::Intensity);
    assert_eq!(embedded.layers, g.params.layers);
    for s in data.iter().take(6) {
        for (e, p) in s.frames.iter().map(|f| (&f.ego, &f.partner)) {
            let f = scorer_core::features(e, p);
            let surr: Surrogates = scorer_core::surrogates(e, p);
            let mut expected = 0.0f32;
            for t in &m.params.terms {
                let kind = parse_configuration(&t.surrogate).unwrap()[0];
                let raw = core.raw(kind, &f, &surr);
                let g = scorer_core::msra::transform(kind, raw, t.lo, t.hi);
                expected += t.w * scorer_core::msra::sigmoid(t.a * g + t.b);
            }
            let got = decoded.score(e, p);
            assert!((got - expected).abs() < 1e-5, "{got} vs {expected}");
        }
    }
    // The trained combination ranks the impact frame of a conflict above a safe frame.
    let c = &data[0];
    let last = c.alert_frames().len() - 1;
    assert!(
        decoded.score(&c.frames[last].ego, &c.frames[last].partner)
            > decoded.score(&data[1].frames[0].ego, &data[1].frames[0].partner)
    );
}

#[test]
fn configuration_defaults_validate_and_typos_are_rejected() {
    GssmConfig::default().validate().unwrap();
    let parsed =
        GssmConfig::from_toml("[fit]\nhidden = [16]\n[ssra]\nscore = \"cdf\"\n", "x.toml").unwrap();
    assert_eq!(parsed.fit.hidden, vec![16]);
    assert_eq!(parsed.ssra.score, SsraScore::Cdf);
    assert!(GssmConfig::from_toml("[fit]\nhiden = [16]\n", "x.toml").is_err());
    assert!(GssmConfig::from_toml("[msra]\nconfigurations = [\"ei+gsm\"]\n", "x.toml").is_err());
    assert!(GssmConfig::from_toml("[fit]\nhidden = [65]\n", "x.toml").is_err());
    // Typed: the network check is the one DRL's configuration uses.
    use riskscore_train::gssm::config::{ConfigurationError, GssmConfigError, InvalidGssmConfig};
    use riskscore_train::train::config::HiddenLayersError;
    match GssmConfig::from_toml("[fit]\nhidden = [65]\n", "x.toml") {
        Err(GssmConfigError::Invalid { path, source }) => {
            assert_eq!(path, "x.toml");
            assert_eq!(
                source,
                InvalidGssmConfig::Hidden(HiddenLayersError { table: "fit" })
            );
        }
        other => panic!("expected an invalid value, got {other:?}"),
    }
    assert_eq!(
        parse_configuration("ei+ei"),
        Err(ConfigurationError::Repeated {
            text: "ei+ei".into(),
            part: "ei".into()
        })
    );
}

#[test]
fn ship_writes_three_decodable_models_on_a_simulated_folder() {
    let dir = tempfile::tempdir().unwrap();
    let events = dir.path().join("events");
    let sim = riskscore_data::sim::SimConfig {
        seed: 3,
        events: 40,
        ..riskscore_data::sim::SimConfig::default()
    };
    riskscore_data::sim::simulate_to_dir(&events, &sim).unwrap();
    // The same tiny configurations as riskctl's `gssm ship` test.
    let tiny = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/tiny");
    let (train_toml, gssm_toml) = (tiny.join("train.toml"), tiny.join("gssm.toml"));
    let train = load_prepared(&events, &PrepareConfig::default())
        .unwrap()
        .sequences;
    let config = TrainConfig::load_or_default(Some(&train_toml), Some(1)).unwrap();
    assert_eq!(config.seed, 1);
    let gssm_config = GssmConfig::load_or_default(Some(&gssm_toml)).unwrap();
    // Without a separate normal-driving folder the GSSM is fitted on the training sequences.
    let kinematic = [
        MsraTerm {
            kind: SurrogateKind::Tadv,
            weight: 4.0,
            a: -2.5,
            b: 12.0,
            lo: 0.0,
            hi: 5.0,
        },
        MsraTerm {
            kind: SurrogateKind::Ei,
            weight: 5.0,
            a: 2.0,
            b: -0.5,
            lo: 0.0,
            hi: 20.0,
        },
    ];
    let shipped = ship(
        &train,
        &train,
        &config,
        &gssm_config,
        Some(&kinematic),
        Progress::Hidden,
    )
    .unwrap();
    assert!(shipped.warnings.is_empty(), "{:?}", shipped.warnings);
    // GSSM and SSRA hand over to the kinematic terms outside the fit data's domain (with its
    // geometry cells); the MSRA over the GSSM is flagged only.
    let policies: Vec<_> = shipped
        .blobs
        .iter()
        .map(|b| {
            let meta = scorer_core::model::decode_blob(b).unwrap().meta;
            let domain = meta
                .training_domain
                .expect("every shipped blob has a domain");
            (
                domain.policy,
                meta.kinematic_fallback.is_some(),
                domain.coverage.is_some(),
            )
        })
        .collect();
    assert_eq!(
        policies,
        [
            (OutsidePolicy::Fallback, true, true),
            (OutsidePolicy::Fallback, true, true),
            (OutsidePolicy::FlagOnly, false, false),
        ]
    );
    // Without the terms the fallback policy is written as flag-only.
    let unpaired = ship(
        &train,
        &train,
        &config,
        &gssm_config,
        None,
        Progress::Hidden,
    )
    .unwrap();
    for b in &unpaired.blobs {
        let domain = scorer_core::model::decode_blob(b)
            .unwrap()
            .meta
            .training_domain;
        assert_eq!(domain.unwrap().policy, OutsidePolicy::FlagOnly);
    }
    let out = dir.path().join("models");
    let written = shipped.write_models(&out).unwrap();
    assert_eq!(written, SHIPPED_FILES.map(|f| out.join(f)));
    let mut names = Vec::new();
    for (path, blob) in written.iter().zip(&shipped.blobs) {
        let bytes = std::fs::read(path).unwrap();
        assert_eq!(&bytes, blob);
        let m = scorer_core::model::decode(&bytes).unwrap();
        names.push(model_row_name(&m));
        let v = m.score(&car(0.0, 0.0, 10.0), &car(12.0, 0.0, 5.0));
        assert!(v.is_finite());
    }
    assert_eq!(names, ["GSSM", "SSRA", "MSRA-GSSM"]);
    let summary = shipped.summary(&config, &gssm_config, std::slice::from_ref(&events), &[]);
    assert_eq!(summary["msra"]["configuration"], "TAdv-corridor+EI+GSSM");
    assert_eq!(summary["seed"], 1);
    assert_eq!(summary["events"][0], events.display().to_string());
    assert_eq!(summary["normal"], serde_json::json!([]));
}
