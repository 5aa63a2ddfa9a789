#!/usr/bin/env bash
# The main job: builds riskctl (release, scripts/build.sh: cold about 10 min on 2 cores with cargo's
# progress shown, seconds when built) and runs the demo on the embedded defaults (about 70-180 s).
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
scripts/build.sh
echo "==> riskctl demo $* (about 1-3 min; progress below, results at the end)"
exec target/release/riskctl demo "$@"
