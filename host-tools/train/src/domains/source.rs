//! The source of a sequence: the simulator, a real freeway recording or real city traffic (and
//! which city). The folder says which source it is (the CLI passes each folder with its role);
//! for city traffic the event id's scenario prefix says the city.
use std::fmt;

use riskscore_data::events::fold_group;

/// Known city scenario prefixes (as `riskctl import commonroad` names NGSIM's CommonRoad
/// scenarios) and the city each belongs to.
const CITY_PREFIXES: [(&str, &str); 2] = [("USA_Lanker", "Lankershim"), ("USA_Peach", "Peachtree")];

/// Where a sequence came from.
#[derive(Clone, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Source {
    /// A simulated folder (training or test simulation).
    Sim,
    /// Real freeway recordings (e.g. NGSIM US-101).
    RealFreeway,
    /// Real city traffic of the named city.
    RealCity(String),
}

impl Source {
    /// The source of a sequence read from a real-city folder: the city of its event id.
    pub fn city_of_event(event_id: &str) -> Source {
        Source::RealCity(city_of(event_id))
    }

    /// True for real recordings (freeway or city).
    pub fn is_real(&self) -> bool {
        !matches!(self, Source::Sim)
    }

    /// The source as a table cell: `sim`, `real-freeway` or `real-city:<city>`.
    pub fn label(&self) -> String {
        match self {
            Source::Sim => "sim".into(),
            Source::RealFreeway => "real-freeway".into(),
            Source::RealCity(city) => format!("real-city:{city}"),
        }
    }
}

impl fmt::Display for Source {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Source::Sim => f.write_str("simulation"),
            Source::RealFreeway => f.write_str("real freeway"),
            Source::RealCity(city) => write!(f, "real city ({city})"),
        }
    }
}

/// The city of a real-city event id: a known scenario prefix names its city (`USA_Lanker-1_...`
/// is Lankershim); any other scenario is its own city, named by its scenario up to the first `-`
/// (so one folder of an unknown city still splits into cities consistently).
pub fn city_of(event_id: &str) -> String {
    let scenario = fold_group(event_id);
    CITY_PREFIXES
        .iter()
        .find(|(prefix, _)| scenario.starts_with(prefix))
        .map_or_else(
            || scenario.split('-').next().unwrap_or(scenario).to_owned(),
            |(_, city)| (*city).to_owned(),
        )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_city_comes_from_the_scenario_prefix() {
        assert_eq!(city_of("USA_Lanker-1_12_T-1/405-410#3"), "Lankershim");
        assert_eq!(city_of("USA_Peach-2_1_T-1/7-9"), "Peachtree");
        assert_eq!(city_of("DEU_Muc-3_1_T-1/1-2"), "DEU_Muc");
        assert_eq!(
            Source::city_of_event("USA_Peach-4_1_T-1/1-2"),
            Source::RealCity("Peachtree".into())
        );
        assert!(Source::RealFreeway.is_real() && !Source::Sim.is_real());
        assert_eq!(Source::Sim.label(), "sim");
        assert_eq!(Source::RealFreeway.label(), "real-freeway");
        assert_eq!(
            Source::RealCity("Lankershim".into()).label(),
            "real-city:Lankershim"
        );
    }
}
