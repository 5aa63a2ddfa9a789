#!/usr/bin/env bash
# The main job: builds riskctl (release) and runs the demo on the embedded defaults.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
cargo run --quiet --release -p host-tools --bin riskctl -- demo "$@"
