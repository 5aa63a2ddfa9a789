//! MSRA: multi-surrogate risk aggregation `R = sum_k w_k * sigmoid(a_k * g_k(f_k) + b_k)`.
//!
//! Each of up to [`MAX_TERMS`] terms reads one surrogate `f_k` ([`SurrogateKind`]): TTC2D, TAdv, EI,
//! TAdv-corridor from [`Surrogates`], or GSSM (the score of the GSSM network embedded in the model, computed from
//! the features). The transform `g_k` ([`transform`]) is the identity clipped to the term's stored
//! range `[lo, hi]`, with the "no conflict" values and NaN sent to the bound that means "no
//! conflict":
//!
//! | kind  | riskier when | `+inf`  | `-inf` | NaN  |
//! |-------|--------------|---------|--------|------|
//! | TTC2D | smaller      | `hi`    | `lo`   | `hi` |
//! | TAdv  | smaller      | `hi`    | `lo`   | `hi` |
//! | TAdv-corridor | smaller | `hi` | `lo`   | `hi` |
//! | EI    | larger       | `hi`    | `lo`   | `lo` |
//! | GSSM  | larger       | `hi`    | `lo`   | `lo` |
//!
//! So infinities never reach the arithmetic and `R` is finite for every input (bounded by
//! `sum_k |w_k|`). The sign of `a_k` is learned: for TTC2D/TAdv it is normally negative.

use serde::{Deserialize, Serialize};

use crate::bounded::BoundedVec;
use crate::features::Features;
use crate::gssm::GssmModel;
use crate::mlp::MAX_ABS_PARAM;
use crate::model_error::ModelError;
use crate::surrogates::{SurrogateKind, Surrogates};

/// Maximum number of MSRA terms.
pub const MAX_TERMS: usize = 4;

/// One term `w * sigmoid(a * g(f) + b)`, `g` = [`transform`] with `[lo, hi]`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct MsraTerm {
    /// The surrogate this term reads.
    pub kind: SurrogateKind,
    /// `w_k`.
    pub weight: f32,
    /// `a_k` (slope on the transformed surrogate).
    pub a: f32,
    /// `b_k` (offset).
    pub b: f32,
    /// Lower clip bound of `g_k` (finite, `< hi`).
    pub lo: f32,
    /// Upper clip bound of `g_k` (finite, `> lo`).
    pub hi: f32,
}

/// An MSRA model: its terms and, when a term reads GSSM, the GSSM network.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct MsraModel<'a> {
    /// The terms, summed in order.
    pub terms: BoundedVec<MsraTerm, MAX_TERMS>,
    /// The GSSM network read by `SurrogateKind::Gssm` terms (its [`GssmModel::score`]).
    #[serde(borrow)]
    pub gssm: Option<GssmModel<'a>>,
}

/// `g_k`: `raw` clipped to `[lo, hi]`; `+inf -> hi`, `-inf -> lo`, NaN -> the "no conflict" bound
/// (`hi` for the times, `lo` for EI/GSSM). For a finite `lo <= hi` the result lies in `[lo, hi]`;
/// for a malformed range (never accepted by model validation) the result is still finite (0 if a
/// bound is NaN).
pub fn transform(kind: SurrogateKind, raw: f32, lo: f32, hi: f32) -> f32 {
    let v = if raw.is_nan() {
        if kind.larger_is_riskier() {
            lo
        } else {
            hi
        }
    } else if raw < lo {
        lo
    } else if raw > hi {
        hi
    } else {
        raw
    };
    if v.is_finite() {
        v
    } else {
        0.0
    }
}

/// Logistic function `1 / (1 + exp(-x))` via `libm::expf`; saturates to exactly 0 or 1.
pub fn sigmoid(x: f32) -> f32 {
    if x.is_nan() {
        return 0.5;
    }
    1.0 / (1.0 + libm::expf(-x))
}

fn check(v: f32, field: &'static str, index: usize) -> Result<(), ModelError> {
    if v.is_finite() && v.abs() <= MAX_ABS_PARAM {
        Ok(())
    } else {
        Err(ModelError::NonFinite { field, index })
    }
}

impl MsraTerm {
    /// Finite, bounded `w`, `a`, `b` and a finite clip range `lo < hi`; `k` names the term.
    pub fn validate(&self, k: usize) -> Result<(), ModelError> {
        check(self.weight, "terms.weight", k)?;
        check(self.a, "terms.a", k)?;
        check(self.b, "terms.b", k)?;
        check(self.lo, "terms.lo", k).map_err(|_| ModelError::BadClipRange { term: k })?;
        check(self.hi, "terms.hi", k).map_err(|_| ModelError::BadClipRange { term: k })?;
        if self.lo >= self.hi {
            return Err(ModelError::BadClipRange { term: k });
        }
        Ok(())
    }

    /// The term's contribution `w * sigmoid(a * g(raw) + b)` for the raw surrogate value; 0 if
    /// that is not finite (it cannot be for a validated term).
    pub fn value(&self, raw: f32) -> f32 {
        let g = transform(self.kind, raw, self.lo, self.hi);
        let v = self.weight * sigmoid(self.a * g + self.b);
        if v.is_finite() {
            v
        } else {
            0.0
        }
    }
}

impl MsraModel<'_> {
    /// Checks term count, finite bounded parameters, clip ranges, and that GSSM terms have a
    /// (valid) GSSM network.
    pub fn validate(&self) -> Result<(), ModelError> {
        self.terms.check_capacity("terms")?;
        if self.terms.is_empty() {
            return Err(ModelError::Empty { field: "terms" });
        }
        for (k, t) in self.terms.iter().enumerate() {
            t.validate(k)?;
            if t.kind == SurrogateKind::Gssm && self.gssm.is_none() {
                return Err(ModelError::MissingGssm { term: k });
            }
        }
        if let Some(g) = &self.gssm {
            g.validate()?;
        }
        Ok(())
    }

    /// The raw surrogate a term of `kind` reads (GSSM: the embedded network's score, NaN without one).
    pub fn raw(&self, kind: SurrogateKind, features: &Features, surrogates: &Surrogates) -> f32 {
        surrogates
            .kinematic(kind)
            .unwrap_or_else(|| self.gssm.as_ref().map_or(f32::NAN, |g| g.score(features)))
    }

    /// Contribution `w_k * sigmoid(a_k * g_k + b_k)` of each term (unused entries 0).
    pub fn term_values(&self, features: &Features, surrogates: &Surrogates) -> [f32; MAX_TERMS] {
        let mut out = [0.0f32; MAX_TERMS];
        // The GSSM score is computed at most once even if several terms read it.
        let mut gssm_raw: Option<f32> = None;
        for (o, t) in out.iter_mut().zip(self.terms.iter()) {
            let raw = if t.kind == SurrogateKind::Gssm {
                *gssm_raw.get_or_insert_with(|| self.raw(t.kind, features, surrogates))
            } else {
                self.raw(t.kind, features, surrogates)
            };
            *o = t.value(raw);
        }
        out
    }

    /// `R`: the sum of the term values, in term order. Finite for every input.
    pub fn score(&self, features: &Features, surrogates: &Surrogates) -> f32 {
        self.term_values(features, surrogates).iter().sum()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn surrogates(ttc2d: f32, tadv: f32, ei: f32) -> Surrogates {
        Surrogates {
            box_distance: 5.0,
            ttc2d,
            tadv,
            tadv_corridor: tadv,
            ei,
        }
    }

    #[test]
    fn transform_maps_infinities_and_nan_to_no_conflict() {
        use SurrogateKind::*;
        assert_eq!(transform(Ttc2d, f32::INFINITY, 0.0, 10.0), 10.0);
        assert_eq!(transform(Tadv, f32::INFINITY, 0.0, 10.0), 10.0);
        assert_eq!(transform(Ei, f32::NEG_INFINITY, -5.0, 5.0), -5.0);
        assert_eq!(transform(Ttc2d, f32::NAN, 0.0, 10.0), 10.0);
        assert_eq!(transform(Tadv, f32::NAN, 0.0, 10.0), 10.0);
        assert_eq!(transform(Ei, f32::NAN, -5.0, 5.0), -5.0);
        assert_eq!(transform(Gssm, f32::NAN, 0.0, 6.0), 0.0);
        assert_eq!(transform(Ttc2d, f32::NEG_INFINITY, 0.0, 10.0), 0.0);
        assert_eq!(transform(Ei, f32::INFINITY, -5.0, 5.0), 5.0);
        assert_eq!(transform(Ttc2d, 3.25, 0.0, 10.0), 3.25);
        assert_eq!(transform(Ttc2d, -1.0, 0.0, 10.0), 0.0);
        assert_eq!(transform(Ei, 7.0, -5.0, 5.0), 5.0);
        // Malformed ranges stay finite and never panic.
        assert!(transform(Ei, 1.0, f32::NAN, f32::NAN).is_finite());
        assert!(transform(Ei, 1.0, 5.0, -5.0).is_finite());
    }

    #[test]
    fn sigmoid_values() {
        assert_eq!(sigmoid(0.0), 0.5);
        assert!((sigmoid(2.0) - 0.880_797_1).abs() < 1e-6);
        assert_eq!(sigmoid(-200.0), 0.0);
        assert_eq!(sigmoid(200.0), 1.0);
        assert_eq!(sigmoid(f32::NAN), 0.5);
    }

    #[test]
    fn score_is_the_weighted_sum_of_sigmoids() {
        let mut terms = BoundedVec::new();
        terms
            .push(MsraTerm {
                kind: SurrogateKind::Ttc2d,
                weight: 0.75,
                a: -1.0,
                b: 2.0,
                lo: 0.0,
                hi: 10.0,
            })
            .unwrap();
        terms
            .push(MsraTerm {
                kind: SurrogateKind::Ei,
                weight: 0.25,
                a: 2.0,
                b: 0.0,
                lo: -4.0,
                hi: 4.0,
            })
            .unwrap();
        let m = MsraModel { terms, gssm: None };
        m.validate().unwrap();
        let f = [0.0f32; crate::FEATURE_COUNT];
        // ttc 1 s: 0.75 * sigmoid(1) ; ei 0.5: 0.25 * sigmoid(1)
        let r = m.score(&f, &surrogates(1.0, 9.0, 0.5));
        let expect = 1.0 / (1.0 + (-1.0f64).exp());
        assert!((f64::from(r) - expect).abs() < 1e-6, "{r}");
        // No conflict: ttc +inf -> 10, ei -inf -> -4.
        let r = m.score(
            &f,
            &surrogates(f32::INFINITY, f32::INFINITY, f32::NEG_INFINITY),
        );
        let expect = 0.75 / (1.0 + 8.0f64.exp()) + 0.25 / (1.0 + 8.0f64.exp());
        assert!((f64::from(r) - expect).abs() < 1e-6, "{r}");
        // Riskier surrogates, larger score.
        let safe = m.score(&f, &surrogates(8.0, 9.0, -3.0));
        let risky = m.score(&f, &surrogates(0.5, 9.0, 2.0));
        assert!(risky > safe);
    }

    #[test]
    fn gssm_term_without_network_is_rejected() {
        let mut terms = BoundedVec::new();
        terms
            .push(MsraTerm {
                kind: SurrogateKind::Gssm,
                weight: 1.0,
                a: 1.0,
                b: 0.0,
                lo: 0.0,
                hi: 6.0,
            })
            .unwrap();
        let m = MsraModel { terms, gssm: None };
        assert_eq!(m.validate(), Err(ModelError::MissingGssm { term: 0 }));
        // Unvalidated, it still scores: the raw GSSM value is NaN -> lo.
        let f = [0.0f32; crate::FEATURE_COUNT];
        assert!((m.score(&f, &surrogates(1.0, 1.0, 1.0)) - 0.5).abs() < 1e-7);
    }
}
