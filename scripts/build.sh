#!/usr/bin/env bash
# The one release build every README section uses: riskctl and can-bridge with one feature set, so
# nothing recompiles between the demo, the CAN walk-through and the benchmarks. Shows cargo's
# progress. Cold on a 2-core machine about 10 minutes (docs/benchmarks.md); a few seconds when
# nothing changed.
set -euo pipefail
cd "$(dirname "$0")/.."
if [ ! -x target/release/riskctl ] || [ ! -x target/release/can-bridge ]; then
  echo "==> building riskctl and can-bridge (release; cold about 10 min on 2 cores, progress below)"
else
  echo "==> checking the release build of riskctl and can-bridge (seconds when nothing changed)"
fi
cargo build --release -p host-tools -p can-bridge
