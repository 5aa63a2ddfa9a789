//! host-tools: the `riskctl` command line (`src/main.rs`, one module per subcommand in `src/cli/`)
//! and the end-to-end main job it runs, [`demo`]. The work itself lives in the library crates
//! beside this one: `riskscore-data` (event folders, simulator, import, CSV scoring, CAN export),
//! `riskscore-eval` (warning protocol, metrics, reports, plots) and `riskscore-train` (comparisons,
//! training, GSSM, quantisation, export, transfer benchmark).
pub mod demo;
pub mod warnings;
