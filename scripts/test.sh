#!/usr/bin/env bash
# The whole test suite, exactly as CI runs it (.ci/run calls this). Installs what it needs first.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh test

# Each step line also says how long the previous one took, so a CI log shows where the time went.
suite_start=$SECONDS step_start=$SECONDS
step() {
  printf '\n[%s; previous step %ds, total %ds]\n==> %s\n' "$(date +%H:%M:%S)" $((SECONDS - step_start)) \
    $((SECONDS - suite_start)) "$*"
  step_start=$SECONDS
}

# Expected times are for a cold clean clone on a 2-core machine (docs/benchmarks.md); a warm run
# takes a fraction. Cargo prints one line per crate it compiles, so a cold run is never silent.
step "cargo fmt --check (seconds)"
cargo fmt --all -- --check

step "cargo clippy, all targets, warnings are errors (cold about 5 min)"
cargo clippy --workspace --all-targets -- -D warnings

step "scorer-core for thumbv7em-none-eabihf, release, no_std (cold about 30 s)"
cargo build -p scorer-core --release --target thumbv7em-none-eabihf

step "ECU firmware crate: fmt + clippy (outside the workspace; its tests run in cargo test)"
tests/firmware/run-tests.sh --lint-only

step "cargo test: building the test binaries (cold about 6 min)"
cargo test --workspace --no-run

step "cargo test: running the workspace tests (about 1-3 min)"
cargo test --workspace --quiet 2>&1 | tee target/test-output.txt

# The VM's static bridge is built without `check`: the crate must lint, build and pass its tests
# that way too (its tests of `check` and `decode` are cfg'd on the feature).
step "can-bridge without its check feature: clippy + tests (cold up to 2 min)"
cargo clippy -p can-bridge --no-default-features --all-targets -- -D warnings
cargo test -p can-bridge --no-default-features --quiet

step "Python package: maturin wheel (dev profile), fresh venv, pytest (cold about 7 min with downloads, warm about 3 min)"
scripts/test-python.sh

step "vcan VM tests: SocketCAN in QEMU (about 1-2 min; the first run downloads the Debian kernel into .cache/vm)"
tests/vm/run.sh

# One closing line over every cargo test binary (the VM and firmware checks above fail the run on
# their own).
awk '/^test result:/ { for (i = 1; i <= NF; i++) { if ($(i) ~ /^passed;?$/) p += $(i-1); if ($(i) ~ /^failed;?$/) f += $(i-1) } }
     END { printf "\ncargo tests: %d passed, %d failed\n", p, f }' target/test-output.txt
printf 'vcan VM step %ds; whole suite %ds\n' $((SECONDS - step_start)) $((SECONDS - suite_start))
