//! Which scenario families a run draws, and how often: the named mixes (`default`, `domain`) and
//! `--families` lists such as `motorway_approach,signal_queue:2`.
use rand_chacha::ChaCha8Rng;

use super::scenarios::Family;

/// Relative draw weights of scenario families.
#[derive(Clone, Debug, PartialEq)]
pub struct FamilyMix {
    name: String,
    weights: Vec<(Family, f64)>,
}

/// The nine original families and their weights. The default data set (and with it the shipped
/// models, the model cards, the demo and the CI learning tests) was made from exactly this list
/// in this order: the draw reads one random number against these weights, so neither may change.
const DEFAULT_WEIGHTS: [(Family, f64); 9] = [
    (Family::LeadBraking, 0.20),
    (Family::StoppedAhead, 0.10),
    (Family::CutIn, 0.13),
    (Family::LaneChange, 0.11),
    (Family::Merge, 0.08),
    (Family::Crossing, 0.13),
    (Family::LeftTurnAcross, 0.09),
    (Family::TurnIntoPath, 0.06),
    (Family::OppositeDrift, 0.10),
];

/// The operating-domain mix (docs/simulator.md, "Family mixes", gives the reasons): the original
/// families at half their default weight, and the motorway, signalised-junction and roadside
/// families for the other half.
const DOMAIN_NEW_WEIGHTS: [(Family, f64); 7] = [
    (Family::MotorwayApproach, 0.10),
    (Family::MotorwayCutIn, 0.07),
    (Family::SignalQueue, 0.10),
    (Family::SignalCrossing, 0.06),
    (Family::SignalLeftTurn, 0.06),
    (Family::SignalRightTurn, 0.05),
    (Family::RoadsideObject, 0.06),
];

impl Default for FamilyMix {
    fn default() -> Self {
        Self {
            name: "default".into(),
            weights: DEFAULT_WEIGHTS.to_vec(),
        }
    }
}

/// A `--families` text that names no usable mix.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum FamilyMixError {
    #[error("families `{text}`: unknown family `{name}` (known: default, domain, {known})")]
    UnknownFamily {
        text: String,
        name: String,
        known: String,
    },
    #[error(
        "families `{text}`: weight of `{name}` is `{weight}`, expected a positive finite number"
    )]
    BadWeight {
        text: String,
        name: String,
        weight: String,
    },
    #[error("families `{text}`: `{name}` is listed twice")]
    Duplicate { text: String, name: String },
    #[error("families `{text}`: no family named")]
    Empty { text: String },
    #[error("families `{text}`: the weights add up to more than the largest number ({max:e})")]
    WeightsOverflow { text: String, max: f64 },
}

impl FamilyMix {
    /// `default` or `domain`.
    pub fn named(name: &str) -> Option<Self> {
        match name {
            "default" => Some(Self::default()),
            "domain" => Some(Self::domain()),
            _ => None,
        }
    }

    /// The operating-domain mix: the original families at half weight, the new ones for the
    /// other half.
    pub fn domain() -> Self {
        Self {
            name: "domain".into(),
            weights: DEFAULT_WEIGHTS
                .iter()
                .map(|&(f, w)| (f, 0.5 * w))
                .chain(DOMAIN_NEW_WEIGHTS)
                .collect(),
        }
    }

    /// The mix as given (`default`, `domain`, or the family list).
    pub fn name(&self) -> &str {
        &self.name
    }

    /// The families and their relative weights, in draw order.
    pub fn weights(&self) -> &[(Family, f64)] {
        &self.weights
    }

    /// Draws a family with probability proportional to its weight (one random number).
    pub(crate) fn draw(&self, rng: &mut ChaCha8Rng) -> Family {
        let total: f64 = self.weights.iter().map(|(_, w)| w).sum();
        let mut r = super::scenarios::uniform(rng, 0.0, total);
        let mut family = self.weights.first().map_or(Family::LeadBraking, |w| w.0);
        for &(f, w) in &self.weights {
            if r < w {
                family = f;
                break;
            }
            r -= w;
        }
        family
    }
}

impl std::fmt::Display for FamilyMix {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.name)
    }
}

impl std::str::FromStr for FamilyMix {
    type Err = FamilyMixError;

    /// `default`, `domain`, or a comma-separated list of family names, each optionally with a
    /// weight (`NAME:W`, default 1).
    fn from_str(text: &str) -> Result<Self, FamilyMixError> {
        let text = text.trim();
        if let Some(m) = Self::named(text) {
            return Ok(m);
        }
        let mut weights: Vec<(Family, f64)> = Vec::new();
        for item in text.split(',').map(str::trim).filter(|s| !s.is_empty()) {
            let (name, weight) = match item.split_once(':') {
                Some((n, w)) => (n.trim(), Some(w.trim())),
                None => (item, None),
            };
            let family = Family::from_name(name).ok_or_else(|| FamilyMixError::UnknownFamily {
                text: text.into(),
                name: name.into(),
                known: Family::ALL.map(Family::name).join(", "),
            })?;
            let w = match weight {
                None => 1.0,
                Some(w) => w
                    .parse::<f64>()
                    .ok()
                    .filter(|x| x.is_finite() && *x > 0.0)
                    .ok_or_else(|| FamilyMixError::BadWeight {
                        text: text.into(),
                        name: name.into(),
                        weight: w.into(),
                    })?,
            };
            if weights.iter().any(|(f, _)| *f == family) {
                return Err(FamilyMixError::Duplicate {
                    text: text.into(),
                    name: name.into(),
                });
            }
            weights.push((family, w));
        }
        if weights.is_empty() {
            return Err(FamilyMixError::Empty { text: text.into() });
        }
        // The draw takes a uniform number below the total: an infinite total panics there.
        if !weights.iter().map(|(_, w)| w).sum::<f64>().is_finite() {
            return Err(FamilyMixError::WeightsOverflow {
                text: text.into(),
                max: f64::MAX,
            });
        }
        Ok(Self {
            name: text.into(),
            weights,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn named_mixes_and_lists_parse_and_errors_name_the_culprit() {
        let d: FamilyMix = "default".parse().unwrap();
        assert_eq!(d, FamilyMix::default());
        assert_eq!(d.weights(), &DEFAULT_WEIGHTS[..]);
        let dom: FamilyMix = " domain ".parse().unwrap();
        let total: f64 = dom.weights().iter().map(|w| w.1).sum();
        assert!((total - 1.0).abs() < 1e-9, "{total}");
        assert_eq!(dom.weights().len(), Family::ALL.len());
        let l: FamilyMix = "motorway_approach, signal_queue:2.5".parse().unwrap();
        assert_eq!(
            l.weights(),
            &[(Family::MotorwayApproach, 1.0), (Family::SignalQueue, 2.5)]
        );
        assert!(matches!(
            "motorway,signal_queue".parse::<FamilyMix>(),
            Err(FamilyMixError::UnknownFamily { name, .. }) if name == "motorway"
        ));
        for bad in [
            "signal_queue:0",
            "signal_queue:x",
            "signal_queue:-1",
            "signal_queue:inf",
        ] {
            assert!(
                matches!(
                    bad.parse::<FamilyMix>(),
                    Err(FamilyMixError::BadWeight { .. })
                ),
                "{bad}"
            );
        }
        assert!(matches!(
            "cut_in,cut_in".parse::<FamilyMix>(),
            Err(FamilyMixError::Duplicate { .. })
        ));
        assert!(matches!(
            " , ".parse::<FamilyMix>(),
            Err(FamilyMixError::Empty { .. })
        ));
        assert!(matches!(
            "motorway_approach:1e308,signal_queue:1e308".parse::<FamilyMix>(),
            Err(FamilyMixError::WeightsOverflow { .. })
        ));
        assert!("motorway_approach:1e307,signal_queue:1e307"
            .parse::<FamilyMix>()
            .is_ok());
    }

    #[test]
    fn draws_follow_the_weights() {
        use rand::SeedableRng;
        let mix: FamilyMix = "cut_in:3,merge:1".parse().unwrap();
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let n = 4000;
        let cut_in = (0..n)
            .filter(|_| mix.draw(&mut rng) == Family::CutIn)
            .count();
        let share = cut_in as f64 / n as f64;
        assert!((share - 0.75).abs() < 0.03, "{share}");
    }
}
