#!/usr/bin/env bash
# CAN bridge benchmarks (not part of the test suite; numbers go to docs/benchmarks.md).
#   tests/vm/bench.sh offline   score-log throughput on one core (release build)
#   tests/vm/bench.sh vcan      in the VM over vcan: BENCH_FPS frames/s (default 8000) for
#                               BENCH_SECONDS (default 60): frames lost, trigger->warning latency
#   tests/vm/bench.sh           both
set -euo pipefail
cd "$(dirname "$0")/../.."
# shellcheck source=tests/vm/lib.sh
. tests/vm/lib.sh
what=${1:-all}
FPS=${BENCH_FPS:-8000}
SECS=${BENCH_SECONDS:-60}
SHARE=$PWD/target/vm/bench
rm -rf "$SHARE" && mkdir -p "$SHARE/bin" "$SHARE/fixtures" "$SHARE/out"
cargo build --quiet -p can-bridge --no-default-features --example vm_fixtures
model_arg=()
[ -f models/drl-default.rsk ] && model_arg=(--model models/drl-default.rsk)
target/debug/examples/vm_fixtures --out "$SHARE/fixtures" --bench-fps "$FPS" --bench-seconds "$SECS" "${model_arg[@]}"
frames=$(wc -l < "$SHARE/fixtures/bench.log")
vm_say "model: $(basename "${model_arg[1]:-synthetic MSRA}"); bench log: $frames frames ($FPS frames/s for $SECS s; ego + 40 object tracks, 1/8 closing in)"

if [ "$what" = offline ] || [ "$what" = all ]; then
  cargo build --quiet --release -p can-bridge --no-default-features --bin can-bridge
  best=0
  for i in 1 2 3; do
    line=$(taskset -c 0 target/release/can-bridge score-log --log "$SHARE/fixtures/bench.log" \
      --model "$SHARE/fixtures/model.rsk" --threshold 1.5 --events-out /dev/null --max-problems 0 --bench 2>&1 \
      | grep -E 'frames/s|engine')
    fps=$(echo "$line" | grep 'frames/s' | sed -E 's/.*score-log: ([0-9]+) frames\/s.*/\1/')
    vm_say "offline run $i: $(echo "$line" | tr '\n' ' ')"
    [ "$fps" -gt "$best" ] && best=$fps
  done
  vm_say "RESULT offline score-log: $best frames/s on one core (parse + decode + score + warnings)"
fi

if [ "$what" = vcan ] || [ "$what" = all ]; then
  vm_check_tools
  cargo build --quiet --release -p can-bridge --no-default-features --bin can-bridge
  vm_stage_binary target/release/can-bridge "$SHARE"
  vm_kernel
  vm_initramfs
  cp tests/vm/bench-guest.sh "$SHARE/guest.sh"
  vm_say "booting the VM (2 vCPUs, TCG) for a ${SECS}s run"
  rc=0
  VM_MEM=1024 VM_TIMEOUT=$((SECS * 3 + 120)) VM_SMP=2 vm_boot "$SHARE" || rc=$?
  [ "$rc" -eq 0 ] || { tail -n 20 "$SHARE/console.log"; vm_fail "bench VM run failed ($rc)"; }
  O=$SHARE/out
  cat "$O/replay.err" "$O/bridge.err" "$O/monitor.err" | grep -v '^can-bridge: [0-9]' || true
  sent=$(sed -E 's/^replay: ([0-9]+) frames sent.*/\1/;t;d' "$O/replay.err")
  got=$(sed -E 's/.*stopped \(Idle\); ([0-9]+) frames,.*/\1/;t;d' "$O/bridge.err")
  vm_say "RESULT vcan: sent $sent, bridge received $got, lost $((sent - got)) at $FPS frames/s for $SECS s (TCG-emulated CPU)"
  vm_say "RESULT vcan latency: $(grep -o 'latency.*' "$O/monitor.err")"
fi
