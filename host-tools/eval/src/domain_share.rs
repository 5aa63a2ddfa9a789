//! How many of the scored frames each guarded model saw outside its training domain, and which
//! input left the range first how often: the `domain` part of `riskctl evaluate`'s report.
use crate::report::format_value;
use scorer_core::model::geometry_coverage::GEOMETRY_INPUT_NAME;
use scorer_core::model::{ModelKind, GEOMETRY_INPUT};
use scorer_core::{Guarded, DRL_INPUT_NAMES, FEATURE_COUNT, FEATURE_NAMES};
use serde_json::{json, Value};

/// One guarded model's frames, outside or not.
#[derive(Clone, Debug, PartialEq)]
pub struct DomainShare {
    /// The row name, as in the metrics table.
    pub name: String,
    pub kind: ModelKind,
    /// Frames scored.
    pub frames: u64,
    /// Frames outside the training domain.
    pub outside: u64,
    /// Per input index: frames on which it was the first input outside its range (the last
    /// slot, [`GEOMETRY_INPUT`]: inside every range, in an uncovered geometry cell).
    pub first_outside: [u64; FEATURE_COUNT + 1],
}

impl DomainShare {
    pub fn new(name: &str, kind: ModelKind) -> Self {
        Self {
            name: name.to_owned(),
            kind,
            frames: 0,
            outside: 0,
            first_outside: [0; FEATURE_COUNT + 1],
        }
    }

    /// Counts one scored frame.
    pub fn add(&mut self, guarded: &Guarded) {
        self.frames += 1;
        if !guarded.in_domain {
            self.outside += 1;
        }
        if let Some(slot) = guarded
            .first_outside
            .and_then(|i| self.first_outside.get_mut(usize::from(i)))
        {
            *slot += 1;
        }
    }

    /// Adds another tally of the same model.
    pub fn merge(&mut self, other: &Self) {
        self.frames += other.frames;
        self.outside += other.outside;
        for (mine, theirs) in self.first_outside.iter_mut().zip(other.first_outside) {
            *mine += theirs;
        }
    }

    /// Percentage of the frames outside (`None` without frames).
    pub fn outside_percent(&self) -> Option<f64> {
        (self.frames > 0).then(|| 100.0 * self.outside as f64 / self.frames as f64)
    }

    /// The name of input `index` of this model's kind (DRL inputs or features, or `geometry`).
    pub fn input_name(&self, index: usize) -> &'static str {
        if index == usize::from(GEOMETRY_INPUT) {
            return GEOMETRY_INPUT_NAME;
        }
        let names = match self.kind {
            ModelKind::DrlInt8 | ModelKind::DrlF32 => &DRL_INPUT_NAMES,
            ModelKind::Msra | ModelKind::Gssm => &FEATURE_NAMES,
        };
        names.get(index).copied().unwrap_or("?")
    }

    /// The inputs that left first, most frequent first (ties in input order), with their counts.
    pub fn leavers(&self) -> Vec<(&'static str, u64)> {
        let mut v: Vec<(usize, u64)> = self
            .first_outside
            .iter()
            .copied()
            .enumerate()
            .filter(|&(_, n)| n > 0)
            .collect();
        v.sort_by(|a, b| b.1.cmp(&a.1).then(a.0.cmp(&b.0)));
        v.into_iter()
            .map(|(i, n)| (self.input_name(i), n))
            .collect()
    }

    /// `{"name", "frames", "outside", "outside_share", "first_outside": {input: frames}}`,
    /// `outside_share` in percent (`null` without frames).
    pub fn to_json(&self) -> Value {
        let first: serde_json::Map<String, Value> = self
            .leavers()
            .into_iter()
            .map(|(name, n)| (name.to_owned(), Value::from(n)))
            .collect();
        json!({
            "name": self.name,
            "frames": self.frames,
            "outside": self.outside,
            "outside_share": self.outside_percent(),
            "first_outside": first,
        })
    }
}

/// The Markdown table of the guarded models (empty text when there is none).
pub fn markdown(shares: &[DomainShare]) -> String {
    if shares.is_empty() {
        return String::new();
    }
    let mut out = String::from(
        "\nOutside the training domain (models with a domain record):\n\n\
         | Method | Frames | Outside (%) | First input outside (frames) |\n\
         |---|---:|---:|---|\n",
    );
    for s in shares {
        let leavers: Vec<String> = s
            .leavers()
            .into_iter()
            .take(3)
            .map(|(name, n)| format!("{name} {n}"))
            .collect();
        let percent = format_value(s.outside_percent(), 2);
        out.push_str(&format!(
            "| {} | {} | {percent} | {} |\n",
            s.name,
            s.frames,
            if leavers.is_empty() {
                "-".to_owned()
            } else {
                leavers.join(", ")
            }
        ));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counts_share_and_leavers() {
        let mut s = DomainShare::new("DRL", ModelKind::DrlInt8);
        let g = |in_domain, first_outside| Guarded {
            score: 0.0,
            in_domain,
            first_outside,
        };
        s.add(&g(true, None));
        s.add(&g(false, Some(3)));
        s.add(&g(false, Some(3)));
        s.add(&g(false, Some(8)));
        let mut other = DomainShare::new("DRL", ModelKind::DrlInt8);
        other.add(&g(true, None));
        other.add(&g(false, Some(GEOMETRY_INPUT)));
        s.merge(&other);
        assert_eq!((s.frames, s.outside), (6, 4));
        assert_eq!(
            s.leavers(),
            vec![("v_ego", 2), ("log_gap", 1), ("geometry", 1)]
        );
        let json = s.to_json();
        assert_eq!(json["first_outside"]["v_ego"], 2);
        assert_eq!(json["first_outside"]["geometry"], 1);
        s.add(&g(true, None));
        s.add(&g(true, None));
        assert_eq!(s.outside_percent(), Some(50.0));
        assert_eq!(s.to_json()["outside_share"], 50.0);
        assert!(markdown(&[s]).contains("| DRL | 8 | 50.00 | v_ego 2, log_gap 1, geometry 1 |"));
        assert_eq!(markdown(&[]), "");
    }
}
