//! The geometry cell of a pair and the geometry-coverage record (tag 4): cells of known
//! geometries, the record's bytes as docs/model-format.md gives them, its round trip, every way it
//! is refused, and the guard calling an in-range observation in an uncovered cell outside.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::indexing_slicing,
    clippy::panic
)]

mod example_blob;

use example_blob::{
    assert_truncations_refused_and_flips_handled, blob_with_records, encode, example_domain,
    example_model, hex,
};

use scorer_core::geometry_cell::{geometry_cell, GEOMETRY_CELLS};
use scorer_core::model::geometry_coverage::COVERAGE_BYTES;
use scorer_core::model::{
    self, GeometryCoverage, ModelBlob, ModelError, ModelMeta, OutsidePolicy, GEOMETRY_INPUT,
};
use scorer_core::{drl_inputs, Observation, VehicleState};

/// The ego at the origin heading +y at 10 m/s; the partner at `(x, y)` heading `(hx, hy)` at
/// 10 m/s; both 4 m x 2 m.
fn pair(x: f32, y: f32, hx: f32, hy: f32) -> (VehicleState, VehicleState) {
    let car = |x, y, hx, hy| VehicleState {
        x,
        y,
        vx: 10.0 * hx,
        vy: 10.0 * hy,
        hx,
        hy,
        length: 4.0,
        width: 2.0,
        ..Default::default()
    };
    (car(0.0, 0.0, 0.0, 1.0), car(x, y, hx, hy))
}

fn cell_of(x: f32, y: f32, hx: f32, hy: f32) -> u8 {
    let (ego, partner) = pair(x, y, hx, hy);
    geometry_cell(&drl_inputs(&ego, &partner))
}

/// `(gap band * 8 + bearing) * 8 + heading`.
fn cell(band: u8, bearing: u8, heading: u8) -> u8 {
    (band * 8 + bearing) * 8 + heading
}

#[test]
fn cells_of_known_geometries() {
    // Following 26 m behind the partner's tail, same heading: band 1, dead ahead, same heading.
    assert_eq!(cell_of(0.0, 30.0, 0.0, 1.0), cell(1, 0, 0));
    // The same 5 m ahead: band 0.
    assert_eq!(cell_of(0.0, 9.0, 0.0, 1.0), cell(0, 0, 0));
    // 60 m ahead, oncoming a little to the ego's right: band 2, heading octant 4.
    assert_eq!(cell_of(0.0, 64.0, 0.1, -0.995), cell(2, 0, 4));
    // 20 m to the right and a little behind, crossing towards the ego's path (106 deg to the left
    // of the ego's heading): bearing octant 2, heading octant 2.
    assert_eq!(cell_of(20.0, -2.0, -0.96, -0.28), cell(1, 2, 2));
    // 20 m to the left and a little ahead, moving away to the left: bearing octant 6.
    assert_eq!(cell_of(-20.0, 2.0, -0.96, -0.28), cell(1, 6, 2));
    // Ahead-right, more right than ahead, crossing from the left: bearing 1, heading 6.
    assert_eq!(cell_of(25.0, 20.0, 0.96, 0.28), cell(1, 1, 6));
    // Close behind, a little to the left, same heading: bearing 4.
    assert_eq!(cell_of(-1.0, -8.0, 0.0, 1.0), cell(0, 4, 0));
    // On an axis the comparisons decide: dead ahead and exactly oncoming is heading octant 3
    // (`s < 0` false, `c < 0` true, `|s| > |c|` false).
    assert_eq!(cell_of(0.0, 64.0, 0.0, -1.0), cell(2, 0, 3));
    // Every cell is below the count.
    let far = cell_of(-100.0, -100.0, 0.7, -0.7);
    assert!(usize::from(far) < GEOMETRY_CELLS);
}

/// The bit set covering exactly `cells`.
fn bits(cells: &[u8]) -> &'static [u8] {
    let mut b = vec![0u8; COVERAGE_BYTES];
    for &c in cells {
        b[usize::from(c / 8)] |= 1 << (c % 8);
    }
    Vec::leak(b)
}

/// The worked example's domain (ego speed 0-40 m/s, log gap -0.75..5) covering `cells`.
fn covered_blob(policy: OutsidePolicy, cells: &[u8]) -> ModelBlob<'static> {
    let domain = example_domain(policy).with_coverage(Some(GeometryCoverage::new(bits(cells))));
    ModelBlob {
        model: example_model(),
        meta: ModelMeta {
            training_domain: Some(domain),
            ..ModelMeta::default()
        },
    }
}

#[test]
fn the_record_follows_the_domain_and_round_trips() {
    let blob = covered_blob(OutsidePolicy::FlagOnly, &[0, 9, 191]);
    let bytes = encode(&blob);
    // Tag 4 after the tag-2 record: 26 body bytes, scheme 1, a 24-byte string.
    let tail = hex(&bytes[bytes.len() - 28..]);
    assert_eq!(
        tail,
        concat!(
            "04",
            "1a",
            "01",
            "18",
            "010200000000000000000000000000000000000000000080"
        )
    );
    let back = model::decode_blob(&bytes).unwrap();
    assert_eq!(back, blob);
    let coverage = back.meta.coverage().unwrap();
    assert_eq!(coverage.covered(), 3);
    assert!(coverage.covers(9) && !coverage.covers(10) && coverage.covers(191));
    assert_truncations_refused_and_flips_handled(&bytes);
}

#[test]
fn bad_coverage_records_are_refused() {
    let domain = encode(&covered_blob(OutsidePolicy::FlagOnly, &[0]));
    // The model and the tag-2 record come first; the coverage record is the last 28 bytes.
    let model_only = encode(&ModelBlob::from(example_model())).len();
    let records = &domain[model_only..];
    let (ranges, coverage) = records.split_at(records.len() - 28);
    let refused = |records: &[u8]| model::decode_blob(&blob_with_records(records)).unwrap_err();
    assert!(matches!(
        refused(coverage),
        ModelError::BadRecord {
            field: "geometry_coverage",
            ..
        }
    ));
    assert_eq!(
        refused(&[ranges, coverage, coverage].concat()),
        ModelError::DuplicateRecord { tag: 4 }
    );
    let mut scheme = coverage.to_vec();
    scheme[2] = 2;
    assert!(matches!(
        refused(&[ranges, &scheme].concat()),
        ModelError::BadRecord {
            field: "geometry_coverage.scheme",
            ..
        }
    ));
    let mut short = coverage[..coverage.len() - 1].to_vec();
    short[1] -= 1;
    short[3] -= 1;
    assert!(matches!(
        refused(&[ranges, &short].concat()),
        ModelError::DimensionMismatch {
            field: "geometry_coverage.cells",
            expected: 24,
            found: 23,
            ..
        }
    ));
    // Only a network's domain (DRL, GSSM) carries cells: an MSRA's terms are kinematic. The
    // encoder refuses too.
    let mut msra = covered_blob(OutsidePolicy::FlagOnly, &[0]);
    msra.model = model::decode(include_bytes!("../../models/msra-default.rsk")).unwrap();
    let mut out = vec![0u8; 4096];
    assert!(matches!(
        model::encode_blob(&msra, &mut out),
        Err(ModelError::BadRecord {
            field: "geometry_coverage",
            ..
        })
    ));
}

#[test]
fn an_in_range_observation_in_an_uncovered_cell_is_outside() {
    let following = cell(1, 0, 0);
    for policy in [OutsidePolicy::FlagOnly, OutsidePolicy::Clamp] {
        let blob = covered_blob(policy, &[following]);
        let unguarded = ModelBlob::from(example_model());
        // Inside every range and in the covered cell.
        let (ego, partner) = pair(0.0, 30.0, 0.0, 1.0);
        let g = blob.score_pair_guarded(&ego, &partner);
        assert!(g.in_domain && g.first_outside.is_none());
        // Inside every range, crossing 20 m to the right: outside, named as the geometry; the
        // score is the model's (clamping cannot move it into a covered cell).
        let (ego, partner) = pair(20.0, 0.0, -1.0, 0.0);
        let g = blob.score_pair_guarded(&ego, &partner);
        assert_eq!(g.first_outside, Some(GEOMETRY_INPUT));
        assert!(!g.in_domain);
        assert_eq!(
            g.score.to_bits(),
            unguarded.score_pair_guarded(&ego, &partner).score.to_bits()
        );
        assert_eq!(g, blob.score_guarded(&Observation::of(&ego, &partner)));
        // A range left first is named before the geometry.
        let (mut ego, partner) = pair(20.0, 0.0, -1.0, 0.0);
        ego.vy = 45.0;
        assert_eq!(
            blob.score_pair_guarded(&ego, &partner).first_outside,
            Some(3)
        );
    }
}

#[test]
fn a_gssm_reads_its_cells_off_the_drl_inputs_and_falls_back_outside_them() {
    // The shipped GSSM carries the cells of the normal driving it was fitted on and the
    // kinematic fallback (docs/domain-guard.md, "The GSSM family").
    let blob = model::decode_blob(include_bytes!("../../models/gssm-default.rsk")).unwrap();
    let domain = blob
        .meta
        .training_domain
        .expect("the shipped GSSM is guarded");
    let coverage = domain.coverage.expect("with geometry cells");
    let fallback = blob
        .meta
        .kinematic_fallback
        .expect("and a kinematic fallback");
    assert_eq!(domain.policy, OutsidePolicy::Fallback);
    let (mut by_cell, mut inside) = (0, 0);
    for (x, y) in [
        (0.0, 20.0),
        (15.0, 15.0),
        (20.0, 0.0),
        (-20.0, 5.0),
        (5.0, -20.0),
    ] {
        for (hx, hy) in [(0.0, 1.0), (1.0, 0.0), (-1.0, 0.0), (0.0, -1.0), (0.6, 0.8)] {
            let (ego, partner) = pair(x, y, hx, hy);
            let g = blob.score_pair_guarded(&ego, &partner);
            // The ECU's path and the host's give the same bits.
            assert_eq!(g, blob.score_guarded(&Observation::of(&ego, &partner)));
            let covered = coverage.covers(geometry_cell(&drl_inputs(&ego, &partner)));
            match g.first_outside {
                Some(GEOMETRY_INPUT) => {
                    assert!(!covered);
                    by_cell += 1;
                }
                None => {
                    assert!(covered);
                    assert_eq!(
                        g.score.to_bits(),
                        blob.model.score(&ego, &partner).to_bits()
                    );
                    inside += 1;
                }
                Some(_) => {}
            }
            if g.first_outside.is_some() {
                let surrogates = Observation::of(&ego, &partner).surrogates;
                assert_eq!(g.score.to_bits(), fallback.score(&surrogates).to_bits());
            }
        }
    }
    assert!(
        by_cell > 0 && inside > 0,
        "{by_cell} by cell, {inside} inside"
    );
}
