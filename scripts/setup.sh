#!/usr/bin/env bash
# Idempotent machine set-up for riskscore on Debian: rustup targets/components and apt packages.
# Quiet when everything is already there. Usage: scripts/setup.sh [test]
#   (no argument) what the demo needs;  test  also what the test suite needs.
set -euo pipefail
want_test=${1:-}

# A /dev/null that is a regular file (some tool removed the device and wrote to the path) feeds its
# contents to every `rustc -` probe cargo runs and breaks all builds; restore the device when root.
if [ ! -c /dev/null ] && [ "$(id -u)" -eq 0 ]; then
  echo "setup: /dev/null is not a character device; recreating it"
  rm -f /dev/null && mknod -m 666 /dev/null c 1 3
fi

need_targets=()
if [ "$want_test" = test ]; then
  for t in thumbv7em-none-eabihf; do
    rustup target list --installed 2>/dev/null | grep -qx "$t" || need_targets+=("$t")
  done
  for c in rustfmt clippy; do
    rustup component list --installed 2>/dev/null | grep -q "^$c" || rustup component add "$c" >/dev/null
  done
fi
if [ ${#need_targets[@]} -gt 0 ]; then
  echo "setup: adding rust targets ${need_targets[*]}"
  rustup target add "${need_targets[@]}" >/dev/null
fi

need_pkgs=()
if [ "$want_test" = test ] || [ "$want_test" = python ]; then
  # The Python package (python/, docs/python.md): an interpreter with venv and pip.
  command -v python3 >/dev/null 2>&1 || need_pkgs+=(python3)
  if ! python3 -c 'import venv, ensurepip' >/dev/null 2>&1; then need_pkgs+=(python3-venv python3-pip); fi
  # pyspark (riskscore.spark's tests) needs Java 17 or later.
  java_major=$(java -version 2>&1 | sed -n 's/.*version "\([0-9]*\).*/\1/p' | head -1)
  [ "${java_major:-0}" -ge 17 ] 2>/dev/null || need_pkgs+=(openjdk-17-jre-headless)
fi
if [ "$want_test" = test ]; then
  # qemu-system-arm: Cortex-M4F firmware parity; qemu-system-x86 + busybox-static + cpio: vcan VM.
  for p in qemu-system-arm qemu-system-x86 busybox-static cpio gcc binutils; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || need_pkgs+=("$p")
  done
fi
if [ ${#need_pkgs[@]} -gt 0 ]; then
  echo "setup: installing apt packages ${need_pkgs[*]}"
  SUDO=""; [ "$(id -u)" -eq 0 ] || SUDO=sudo
  export DEBIAN_FRONTEND=noninteractive
  $SUDO apt-get update -qq >/dev/null
  $SUDO apt-get install -y -qq --no-install-recommends "${need_pkgs[@]}" >/dev/null
fi

# The Python build and test environment: maturin, pytest, pyarrow, numpy, pandas, polars at the
# pinned versions, in .cache/pyenv. Reinstalled only when python/requirements.txt changes.
if [ "$want_test" = test ] || [ "$want_test" = python ]; then
  root=$(cd "$(dirname "$0")/.." && pwd)
  venv=$root/.cache/pyenv
  stamp=$venv/.requirements.sha256
  want=$(sha256sum "$root/python/requirements.txt" | cut -d' ' -f1)
  if [ ! -x "$venv/bin/python" ] || [ "$(cat "$stamp" 2>/dev/null)" != "$want" ]; then
    echo "setup: installing the Python test environment into .cache/pyenv (python/requirements.txt)"
    [ -x "$venv/bin/python" ] || python3 -m venv "$venv"
    "$venv/bin/python" -m pip install --quiet --disable-pip-version-check -r "$root/python/requirements.txt"
    echo "$want" > "$stamp"
  fi
fi
