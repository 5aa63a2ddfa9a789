//! Objective and training: the loss, gradient steps that lower it, MSRA recovering a known monotone
//! relation, the validation split, and the TOML configuration.
use candle_core::{Device, Tensor};
use riskscore_data::events::Sequence;
use riskscore_train::comparisons::{
    self, ComparisonConfig, ComparisonSet, ObservationTable, Pair, RowOrigin, Source,
};
use riskscore_train::train::config::{ObjectiveConfig, OptimiserConfig};
use riskscore_train::train::{self, drl, msra, objective, Progress, RiskModel, TrainConfig};
use scorer_core::{Observation, SurrogateKind, Surrogates, FEATURE_COUNT};

mod common;
use common::{conflict, following};

fn safe(id: usize) -> Sequence {
    let v = 12.0 + id as f32 % 7.0;
    let gap = 25.0 + 3.0 * (id % 5) as f32;
    following(id, v, gap, 0.0)
}

fn dataset(n: usize) -> Vec<Sequence> {
    (0..n)
        .flat_map(|i| [conflict(i, 5.0 + (i % 8) as f32, 0.0), safe(i)])
        .collect()
}

/// [`common::quick_config`] with more pairs and epochs: these tests check what training learns.
fn small_config() -> TrainConfig {
    let mut c = common::quick_config();
    c.comparisons.temporal.pairs = 500;
    c.comparisons.cross_sequence.pairs = 500;
    c.comparisons.physics.pairs = 300;
    c.optimiser.max_epochs = 15;
    c
}

#[test]
fn neg_log_sigmoid_is_exact_and_stable() {
    let d = Tensor::new(&[-100f32, -3.0, 0.0, 2.0, 100.0], &Device::Cpu).unwrap();
    let v = objective::neg_log_sigmoid(&d)
        .unwrap()
        .to_vec1::<f32>()
        .unwrap();
    let reference = |x: f64| (1.0 + (-x).exp()).ln();
    for (got, x) in v.iter().zip([-100f64, -3.0, 0.0, 2.0, 100.0]) {
        let want = if x < -50.0 { -x } else { reference(x) };
        assert!(
            (*got as f64 - want).abs() < 1e-5 * (1.0 + want),
            "{x}: {got} vs {want}"
        );
    }
}

#[test]
fn objective_terms_follow_their_definitions() {
    let dev = Device::Cpu;
    let w = Tensor::new(&[2f32, 0.0], &dev).unwrap();
    let l = Tensor::new(&[0f32, 1.0], &dev).unwrap();
    let pw = Tensor::new(&[1f32, 3.0], &dev).unwrap();
    let impact = Tensor::new(&[3f32, 5.0], &dev).unwrap();
    let upper = Tensor::new(&[1f32, 4.0, 3.5], &dev).unwrap();
    let cfg = ObjectiveConfig {
        lambda_impact: 0.5,
        lambda_upper: 2.0,
        r_star: 4.0,
        u: 3.0,
    };
    let (_, parts) = objective::objective(&w, &l, &pw, &impact, &upper, &cfg).unwrap();
    let nls = |d: f64| (1.0 + (-d).exp()).ln();
    let pair = (1.0 * nls(2.0) + 3.0 * nls(-1.0)) / 2.0;
    let imp = (1.0 + 1.0) / 2.0;
    let up = (0.0 + 1.0 + 0.25) / 3.0;
    assert!((parts.pair - pair).abs() < 1e-5);
    assert!((parts.impact - imp).abs() < 1e-6);
    assert!((parts.upper - up).abs() < 1e-6);
    assert!((parts.total - (pair + 0.5 * imp + 2.0 * up)).abs() < 1e-5);
}

#[test]
fn gradient_steps_lower_the_objective_and_rank_conflicts_higher() {
    let seqs = dataset(16);
    let cfg = small_config();
    let prepared = train::prepare_comparisons(&seqs, None, &cfg);
    let scaler = drl::FeatureScaler::fit(&seqs);
    let model = drl::Drl::new(scaler, &cfg.drl.hidden, cfg.seed).unwrap();
    let settings = train::TrainSettings {
        objective: &cfg.objective,
        optimiser: &cfg.optimiser,
        learning_rate: 1e-2,
        seed: cfg.seed,
        progress: Progress::Hidden,
        beta: None,
    };
    let report =
        train::train_with(&model, &prepared.fit, Some(&prepared.validation), &settings).unwrap();
    let first = report.history.first().unwrap();
    let best = &report.history[report.best_epoch - 1];
    assert!(
        best.train.total < 0.7 * first.train.total,
        "{} -> {}",
        first.train.total,
        best.train.total
    );
    assert!(report.epochs_per_second > 0.0);
    // The trained score orders most comparisons correctly.
    let scores = train::score_table(&model, &prepared.fit.table).unwrap();
    let correct = prepared
        .fit
        .pairs
        .iter()
        .filter(|p| scores[p.winner as usize] > scores[p.loser as usize])
        .count();
    assert!(
        correct as f64 > 0.85 * prepared.fit.pairs.len() as f64,
        "{correct}/{}",
        prepared.fit.pairs.len()
    );
}

#[test]
fn training_is_deterministic_in_the_seed() {
    let seqs = dataset(8);
    let mut cfg = small_config();
    cfg.optimiser.max_epochs = 3;
    let run = |cfg: &TrainConfig| {
        let prepared = train::prepare_comparisons(&seqs, None, cfg);
        train::train_drl(&seqs, &prepared, cfg, Progress::Hidden)
            .unwrap()
            .params
    };
    assert_eq!(run(&cfg), run(&cfg));
    let mut other = cfg.clone();
    other.seed += 1;
    assert_ne!(run(&cfg), run(&other));
}

/// An observation with only a TTC.
fn ttc_observation(ttc: f32) -> Observation {
    Observation {
        features: [0.0; FEATURE_COUNT],
        surrogates: Surrogates {
            box_distance: 10.0,
            ttc2d: ttc,
            tadv: f32::INFINITY,
            tadv_corridor: f32::INFINITY,
            ei: f32::NEG_INFINITY,
        },
        drl_inputs: [0.0; FEATURE_COUNT],
    }
}

/// Observations with only a TTC: the truth is "smaller TTC is riskier".
fn ttc_table(ttcs: &[f32]) -> ObservationTable {
    let mut t = ObservationTable::default();
    for &ttc in ttcs {
        t.push_computed(ttc_observation(ttc), RowOrigin::External);
    }
    t
}

#[test]
fn msra_recovers_a_known_monotone_relation() {
    // TTC values spread over the clip range, plus "no conflict" (+inf, clipped to hi).
    let ttcs: Vec<f32> = (0..200)
        .map(|i| {
            if i % 10 == 9 {
                f32::INFINITY
            } else {
                0.05 * i as f32
            }
        })
        .collect();
    let table = ttc_table(&ttcs);
    let mut pairs = Vec::new();
    let mut state = 12345u64;
    let mut next = |n: usize| {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((state >> 33) as usize) % n
    };
    while pairs.len() < 2000 {
        let (i, j) = (next(ttcs.len()), next(ttcs.len()));
        if ttcs[i] < ttcs[j].min(10.0) {
            pairs.push(Pair {
                winner: i as u32,
                loser: j as u32,
                source: Source::Temporal,
                weight: 1.0,
            });
        }
    }
    let set = ComparisonSet {
        table,
        pairs,
        beta: [1.0; 4],
        ..ComparisonSet::default()
    };
    let model = msra::Msra::from_table(
        &[(
            SurrogateKind::Ttc2d,
            msra::default_range(SurrogateKind::Ttc2d),
        )],
        &set.table,
    )
    .unwrap();
    // MSRA's own decay (`msra.weight_decay`), as before DRL's default rose to 0.5.
    let opt = OptimiserConfig {
        max_epochs: 60,
        patience: 60,
        ..TrainConfig::default().msra_optimiser()
    };
    let objective = ObjectiveConfig {
        lambda_impact: 0.0,
        lambda_upper: 0.0,
        ..ObjectiveConfig::default()
    };
    let settings = train::TrainSettings {
        objective: &objective,
        optimiser: &opt,
        learning_rate: 5e-2,
        seed: 1,
        progress: Progress::Hidden,
        beta: None,
    };
    train::train_with(&model, &set, None, &settings).unwrap();
    let p = model.params().unwrap();
    let t = &p.terms[0];
    // R decreasing in TTC: w * a < 0.
    assert!(t.w * t.a < 0.0, "w {} a {}", t.w, t.a);
    // And the deployed MSRA (scorer-core) is monotone on a grid and ranks the training pairs.
    let blob = riskscore_train::export::msra_blob(&p).unwrap();
    let m = scorer_core::model::decode(&blob).unwrap();
    let score = |ttc: f32| m.score_observation(&ttc_observation(ttc));
    let grid: Vec<f32> = (0..=100).map(|i| 0.1 * i as f32).collect();
    for w in grid.windows(2) {
        assert!(score(w[0]) >= score(w[1]), "not monotone at {}", w[0]);
    }
    assert!(score(0.5) - score(9.5) > 0.5);
    // The candle forward and the core agree on the deployed form.
    let float = train::score_table(&model, &set.table).unwrap();
    for (k, &ttc) in ttcs.iter().enumerate().take(50) {
        assert!((float[k] - score(ttc)).abs() < 1e-4, "{ttc}");
    }
}

#[test]
fn validation_split_is_by_event_and_stratified() {
    let mut seqs = dataset(20);
    // Two sequences of one event must stay together.
    let mut twin = seqs[0].clone();
    twin.frames.iter_mut().for_each(|f| f.time += 100.0);
    seqs.push(twin);
    let (fit, val) = train::split_validation(&seqs, 0.25, 3);
    assert_eq!(fit.len() + val.len(), seqs.len());
    let fit_ids: std::collections::BTreeSet<_> = fit.iter().map(|s| &s.event_id).collect();
    for s in &val {
        assert!(!fit_ids.contains(&s.event_id), "{} in both", s.event_id);
    }
    let conflicts = val.iter().filter(|s| s.is_conflict()).count();
    let safes = val.len() - conflicts;
    assert!(
        (4..=6).contains(&conflicts) && (4..=6).contains(&safes),
        "{conflicts} {safes}"
    );
    assert_eq!(train::split_validation(&seqs, 0.25, 3).1, val);
}

#[test]
fn config_defaults_parse_and_typos_are_rejected() {
    let cfg = TrainConfig::from_toml("", "empty.toml").unwrap();
    assert_eq!(cfg, TrainConfig::default());
    let text = "seed = 5\n[objective]\nr_star = 5.0\n[comparisons.temporal]\ndmax = 2.0\n";
    let cfg = TrainConfig::from_toml(text, "x.toml").unwrap();
    assert_eq!(cfg.seed, 5);
    assert_eq!(cfg.objective.r_star, 5.0);
    assert_eq!(cfg.comparisons.temporal.dmax, 2.0);
    assert_eq!(
        cfg.comparisons.temporal.pairs,
        ComparisonConfig::default().temporal.pairs
    );
    let err = TrainConfig::from_toml("[objective]\nr_starr = 1.0\n", "bad.toml").unwrap_err();
    assert!(
        err.to_string().contains("bad.toml") && err.to_string().contains("r_starr"),
        "{err}"
    );
    let err = TrainConfig::from_toml("[objective]\nu = 9.0\n", "bad.toml").unwrap_err();
    assert!(err.to_string().contains("u < r_star"), "{err}");
    // The shipped configuration is the documented defaults.
    let shipped = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../configs/train.toml");
    assert_eq!(TrainConfig::load(&shipped).unwrap(), TrainConfig::default());
}

#[test]
fn config_errors_are_typed_and_keep_their_source() {
    use riskscore_train::train::config::{ConfigError, HiddenLayersError, InvalidConfig};
    use std::error::Error as _;
    let err = TrainConfig::from_toml("[drl]\nhidden = []\n", "net.toml").unwrap_err();
    match &err {
        ConfigError::Invalid { path, source } => {
            assert_eq!(path, "net.toml");
            assert_eq!(
                *source,
                InvalidConfig::Hidden(HiddenLayersError { table: "drl" })
            );
        }
        other => panic!("expected an invalid value, got {other:?}"),
    }
    assert_eq!(
        err.to_string(),
        "net.toml: drl.hidden: 1 to 3 hidden layers of width 1..=64 (the core runs at most 4 layers)"
    );
    let err = TrainConfig::from_toml("seed = \"x\"\n", "p.toml").unwrap_err();
    assert!(matches!(err, ConfigError::Parse { .. }), "{err:?}");
    assert!(
        err.source().is_some(),
        "the TOML error is kept as the source"
    );
}

#[test]
fn msra_overrides_parse_validate_and_name_their_key() {
    let text = "[msra]\ntime_clip = 3.0\nbeta = [1.0, 0.5, 0.0, 0.0]\n[msra.objective]\nlambda_impact = 0.25\n";
    let cfg = TrainConfig::from_toml(text, "m.toml").unwrap();
    assert_eq!(cfg.msra.time_clip, 3.0);
    assert_eq!(cfg.msra.beta, Some([1.0, 0.5, 0.0, 0.0]));
    let o = cfg.msra.objective.as_ref().unwrap();
    assert_eq!(o.lambda_impact, 0.25);
    // Keys missing from the override take the built-in defaults.
    assert_eq!(o.r_star, ObjectiveConfig::default().r_star);
    assert_eq!(cfg.msra.range(SurrogateKind::Tadv), (0.0, 3.0));
    assert_eq!(cfg.msra.range(SurrogateKind::Ttc2d), (0.0, 3.0));
    assert_eq!(
        cfg.msra.range(SurrogateKind::Ei),
        msra::default_range(SurrogateKind::Ei)
    );
    for (bad, key) in [
        ("[msra]\ntime_clip = 0.0\n", "msra.time_clip"),
        ("[msra]\nbeta = [1.0, -1.0, 0.0, 0.0]\n", "msra.beta"),
        ("[msra.objective]\nu = 9.0\n", "msra.objective"),
        ("[msra.objective]\nlambda = 1.0\n", "lambda"),
    ] {
        let err = TrainConfig::from_toml(bad, "bad.toml")
            .unwrap_err()
            .to_string();
        assert!(err.contains(key), "{bad:?}: {err}");
    }
}

#[test]
fn msra_trains_with_its_own_clip_weights_and_objective() {
    let seqs = dataset(16);
    let mut cfg = small_config();
    cfg.msra.surrogates = vec!["ttc2d".into(), "tadv".into()];
    cfg.msra.time_clip = 4.0;
    let prepared = train::prepare_comparisons(&seqs, None, &cfg);
    let trained = train::train_msra(&seqs, &prepared, &cfg, Progress::Hidden).unwrap();
    assert!(trained
        .params
        .terms
        .iter()
        .all(|t| t.lo == 0.0 && t.hi == 4.0));
    // The overrides reach the trainer: other source weights or another objective give other
    // parameters from the same pairs and seed.
    let mut reweighted = cfg.clone();
    reweighted.msra.beta = Some([1.0, 0.1, 0.1, 0.0]);
    let other = train::train_msra(&seqs, &prepared, &reweighted, Progress::Hidden).unwrap();
    assert_ne!(other.params, trained.params);
    let mut anchored = cfg.clone();
    anchored.msra.objective = Some(ObjectiveConfig {
        lambda_impact: 5.0,
        ..ObjectiveConfig::default()
    });
    let other = train::train_msra(&seqs, &prepared, &anchored, Progress::Hidden).unwrap();
    assert_ne!(other.params, trained.params);
    // DRL ignores MSRA's overrides.
    let drl_a = train::train_drl(&seqs, &prepared, &cfg, Progress::Hidden).unwrap();
    let drl_b = train::train_drl(&seqs, &prepared, &anchored, Progress::Hidden).unwrap();
    assert_eq!(drl_a.params, drl_b.params);
}

#[test]
fn drl_forward_matches_the_core_float_network() {
    let seqs = dataset(6);
    let scaler = drl::FeatureScaler::fit(&seqs);
    let model = drl::Drl::new(scaler, &[16, 8], 4).unwrap();
    let params = model.params().unwrap();
    let blob = riskscore_train::export::drl_f32_blob(&params).unwrap();
    let core = scorer_core::model::decode(&blob).unwrap();
    let set = comparisons::build(&seqs, None, &ComparisonConfig::default().scaled(0.02), 1);
    let float = train::score_table(&model, &set.table).unwrap();
    for (k, ((f, s), x)) in set
        .table
        .features
        .iter()
        .zip(&set.table.surrogates)
        .zip(&set.table.drl_inputs)
        .enumerate()
    {
        let o = Observation {
            features: *f,
            surrogates: *s,
            drl_inputs: *x,
        };
        let c = core.score_observation(&o);
        assert!(
            (c - float[k]).abs() < 1e-4 * (1.0 + c.abs()),
            "{c} vs {}",
            float[k]
        );
    }
    assert_eq!(model.input_width(), FEATURE_COUNT);
}
