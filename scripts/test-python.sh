#!/usr/bin/env bash
# The Python package's test step (scripts/test.sh runs it): build the `riskscore` wheel with
# maturin from the workspace's dev profile (so the Arrow crates compiled for the Rust tests are
# reused), install it into a fresh venv with the pinned dependencies, and run python/tests with
# pytest. The parity tests compare with target/debug/riskctl (built by `cargo test --no-run`).
# Usage: scripts/test-python.sh [pytest arguments...]
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh python
tools=.cache/pyenv/bin
wheels=target/wheels

rm -f "$wheels"/riskscore-*.whl
"$tools/maturin" build --quiet --profile dev --manifest-path python/Cargo.toml \
  --interpreter "$tools/python" --out "$wheels"

# A fresh venv each run: the test sees exactly what `pip install riskscore-*.whl` gives a user.
# Dependencies come from pip's cache after the first run.
fresh=target/python-test-venv
rm -rf "$fresh"
"$tools/python" -m venv "$fresh"
"$fresh/bin/python" -m pip install --quiet --disable-pip-version-check \
  -r python/requirements.txt "$wheels"/riskscore-*.whl

# Run from outside the source tree so `import riskscore` is the installed wheel, not python/riskscore.
# The dev wheel's core is unoptimised: the Spark parity run uses 200,000 rows here; the million-row
# run is part of scripts/bench-python.sh (release).
RISKSCORE_SPARK_ROWS=${RISKSCORE_SPARK_ROWS:-200000} \
RISKCTL=${RISKCTL:-$PWD/target/debug/riskctl} "$fresh/bin/python" -m pytest -q -p no:cacheprovider \
  --rootdir python/tests python/tests "$@"
