#!/usr/bin/env bash
# The whole test suite, exactly as CI runs it (.ci/run calls this). Installs what it needs first.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh test

step() { printf '\n==> %s\n' "$*"; }

step "cargo fmt --check"
cargo fmt --all -- --check

step "cargo clippy (all targets, warnings are errors)"
cargo clippy --workspace --all-targets --quiet -- -D warnings

step "scorer-core for thumbv7em-none-eabihf (release, no_std)"
cargo build --quiet -p scorer-core --release --target thumbv7em-none-eabihf

step "ECU firmware crate: fmt + clippy (outside the workspace; its tests run in cargo test)"
tests/firmware/run-tests.sh --lint-only

step "cargo test (workspace)"
cargo test --workspace --quiet 2>&1 | tee target/test-output.txt

step "vcan VM tests (SocketCAN in QEMU; Debian kernel cached in .cache/vm)"
tests/vm/run.sh

# One closing line over every cargo test binary (the VM and firmware checks above fail the run on
# their own).
awk '/^test result:/ { for (i = 1; i <= NF; i++) { if ($(i) ~ /^passed;?$/) p += $(i-1); if ($(i) ~ /^failed;?$/) f += $(i-1) } }
     END { printf "\ncargo tests: %d passed, %d failed\n", p, f }' target/test-output.txt
