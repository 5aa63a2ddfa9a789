#!/usr/bin/env bash
# Entry point for the ECU tests: the C ABI test (gcc + libscorer_ffi.a) and the Cortex-M4F firmware
# parity run under QEMU, plus fmt/clippy of the firmware crate, which workspace-wide cargo commands
# do not reach (tests/firmware is excluded from the workspace: it only builds for
# thumbv7em-none-eabihf).
#
#   tests/firmware/run-tests.sh              lint the firmware, then run scorer-ffi's tests,
#                                            tests/tests/ffi_c.rs and tests/tests/firmware_parity.rs
#   tests/firmware/run-tests.sh --lint-only  only the firmware fmt/clippy (for scripts/test.sh,
#                                            whose `cargo test --workspace` already runs the tests)
# Idempotent; needs what `scripts/setup.sh test` installs (qemu-system-arm, gcc, the target).
set -euo pipefail
cd "$(dirname "$0")/../.."

missing=()
command -v qemu-system-arm >/dev/null || missing+=("qemu-system-arm (apt)")
command -v gcc >/dev/null || missing+=("gcc (apt)")
command -v readelf >/dev/null || missing+=("readelf (apt binutils)")
rustup target list --installed 2>/dev/null | grep -qx thumbv7em-none-eabihf \
  || missing+=("rust target thumbv7em-none-eabihf")
if [ ${#missing[@]} -gt 0 ]; then
  echo "run-tests: missing ${missing[*]}; run scripts/setup.sh test" >&2
  exit 1
fi

echo "==> firmware: cargo fmt --check"
cargo fmt --manifest-path tests/firmware/Cargo.toml -- --check
echo "==> firmware: cargo clippy (thumbv7em-none-eabihf, warnings are errors)"
(cd tests/firmware && cargo clippy --quiet --release --target thumbv7em-none-eabihf \
  --target-dir ../../target/firmware --all-targets -- -D warnings)
[ "${1:-}" = "--lint-only" ] && exit 0

echo "==> scorer-ffi tests (header drift)"
cargo test --quiet -p scorer-ffi
echo "==> C ABI test and Cortex-M4F firmware parity"
cargo test --quiet -p riskscore-tests --test ffi_c --test firmware_parity
