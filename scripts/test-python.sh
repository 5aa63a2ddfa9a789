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
step_start=$SECONDS
"$tools/maturin" build --quiet --profile dev --manifest-path python/Cargo.toml \
  --interpreter "$tools/python" --out "$wheels"
echo "test-python: wheel built in $((SECONDS - step_start)) s"

# A fresh venv each run with the wheel and its declared dependencies (pyarrow, numpy at the pinned
# versions): `import riskscore` sees exactly what `pip install riskscore-*.whl` gives a user.
# The test-only tools (pytest, pandas, polars, pyspark: 600 MB) are not reinstalled into it: a .pth
# file appends .cache/pyenv's site-packages after the venv's own, so the wheel and its
# dependencies still come from the fresh venv.
fresh=target/python-test-venv
step_start=$SECONDS
rm -rf "$fresh"
"$tools/python" -m venv "$fresh"
"$fresh/bin/python" -m pip install --quiet --disable-pip-version-check -c python/requirements.txt \
  "$wheels"/riskscore-*.whl
site_of() { "$1" -c 'import sysconfig; print(sysconfig.get_paths()["purelib"])'; }
site_of "$tools/python" > "$(site_of "$fresh/bin/python")/zz-riskscore-test-tools.pth"
echo "test-python: fresh venv with the wheel in $((SECONDS - step_start)) s"

# pytest puts python/tests on sys.path, not python/: `import riskscore` is the installed wheel.
# The Spark parity run takes 1,000,000 rows (the issue's size; about 95 s on a loaded 2-core
# machine: scorer-core is optimised in dev builds too); RISKSCORE_SPARK_ROWS sets another size.
# riskctl is the one scripts/test.sh's `cargo test` built: under $CARGO_TARGET_DIR when that is
# set (not a stale target/debug/riskctl), unless RISKCTL names one.
cargo_target=${CARGO_TARGET_DIR:-target}
case $cargo_target in /*) ;; *) cargo_target=$PWD/$cargo_target ;; esac
RISKSCORE_SPARK_ROWS=${RISKSCORE_SPARK_ROWS:-1000000} \
RISKCTL=${RISKCTL:-$cargo_target/debug/riskctl} "$fresh/bin/python" -m pytest -q -p no:cacheprovider \
  --rootdir python/tests python/tests "$@"
