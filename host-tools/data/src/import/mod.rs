//! Importers: recorded data in other formats to event folders.
//!
//! - [`commonroad`]: CommonRoad scenario XML (e.g. NGSIM US-101) to real safe interactions.
pub mod commonroad;
