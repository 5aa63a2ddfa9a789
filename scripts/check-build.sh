#!/usr/bin/env bash
# Checks two promises the README makes a newcomer about builds, and prints the figures quoted in
# docs/benchmarks.md:
#   1. the demo's build (scripts/build.sh, what scripts/demo.sh runs) shows cargo's progress within
#      5 s of starting;
#   2. the README's CAN section build (scripts/build.sh again) then compiles 0 crates.
#
# Usage: scripts/check-build.sh [--cold]
#   --cold  build into a fresh temporary target folder: a fresh clone's situation (about 10 min on
#           2 cores); it is removed at the end. Without it the repository's target/ is used, which
#           is only cold if nothing was built there yet.
set -euo pipefail
cd "$(dirname "$0")/.."

scratch=$(mktemp -d)
cleanup() { rm -rf "$scratch"; }
trap cleanup EXIT
if [ "${1:-}" = --cold ]; then
  export CARGO_TARGET_DIR=$scratch/target
elif [ -n "${1:-}" ]; then
  echo "usage: scripts/check-build.sh [--cold]" >&2
  exit 2
fi

# Runs scripts/build.sh, stamping each output line with the seconds since the start.
stamped_build() {
  local start
  start=$(date +%s%N)
  scripts/build.sh 2>&1 | while IFS= read -r line; do
    local ms=$((($(date +%s%N) - start) / 1000000))
    printf '%d.%02d %s\n' $((ms / 1000)) $((ms % 1000 / 10)) "$line"
  done
}

echo "==> 1. the demo's build (scripts/build.sh)"
stamped_build > "$scratch/first.log"
awk '$2 == "Compiling" && !shown { print; shown = 1 } $2 == "Finished" { print }' "$scratch/first.log"
first=$(awk '$2 ~ /^(Updating|Locking|Downloading|Downloaded|Compiling|Checking|Finished)$/ { print $1; exit }' \
  "$scratch/first.log")
total=$(tail -n1 "$scratch/first.log" | cut -d' ' -f1)
compiled=$(grep -cE '^[0-9.]+ +Compiling' "$scratch/first.log" || true)

echo "==> 2. the README's CAN section build (scripts/build.sh again)"
stamped_build > "$scratch/second.log"
again=$(grep -cE '^[0-9.]+ +Compiling' "$scratch/second.log" || true)
second_total=$(tail -n1 "$scratch/second.log" | cut -d' ' -f1)

echo
echo "demo build: first cargo progress line after ${first:-never} s; $compiled crates compiled in $total s"
echo "CAN section build after it: $again crates compiled in $second_total s"
status=0
if [ -z "$first" ] || [ "${first%%.*}" -ge 5 ]; then
  echo "FAIL: no cargo progress within 5 s" >&2
  status=1
fi
if [ "$again" != 0 ]; then
  echo "FAIL: the second build compiled $again crates (it must reuse the demo's build):" >&2
  awk '$2 == "Compiling"' "$scratch/second.log" >&2
  status=1
fi
[ "$status" = 0 ] && echo "OK"
exit "$status"
