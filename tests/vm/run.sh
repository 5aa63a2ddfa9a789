#!/usr/bin/env bash
# SocketCAN tests over vcan in a throw-away QEMU VM (Debian kernel, busybox initramfs, TCG).
# The one entry point for scripts/test.sh. Idempotent; caches the kernel under .cache/vm/.
# Checks: a corrupt model is refused; a simulated drive replayed over vcan gives exactly the
# offline warnings (frame for frame, E2E counters included), verified by a second socket; faults
# on the bus are counted without disturbing healthy tracks; a vanishing or missing interface ends
# the bridge with exit code 2 and a clear message. See tests/vm/README.md.
set -euo pipefail
cd "$(dirname "$0")/../.."
# shellcheck source=tests/vm/lib.sh
. tests/vm/lib.sh
started=$(date +%s)
failures=()
check() { # check DESCRIPTION COMMAND...
  local what=$1; shift
  if "$@"; then vm_say "ok: $what"; else vm_say "FAILED: $what"; failures+=("$what"); fi
}

vm_check_tools
SHARE=$PWD/target/vm/run
rm -rf "$SHARE" && mkdir -p "$SHARE/bin" "$SHARE/fixtures" "$SHARE/out"

vm_say "building (riskctl, can-bridge and the fixture writer; the guest runs this can-bridge)"
# The whole workspace's binaries and examples: the same feature set as `cargo test --workspace`,
# so after scripts/test.sh's test build this is a no-op. (`-p can-bridge` alone resolves other
# features for shared dependencies and rebuilt half the dependency tree: 13+ min cold in CI.)
cargo build --quiet --workspace --bins --examples || vm_fail "building riskctl, can-bridge and vm_fixtures failed"
RISKCTL=target/debug/riskctl
BRIDGE=target/debug/can-bridge
vm_stage_binary "$BRIDGE" "$SHARE"

vm_say "simulating a drive and encoding it as CAN traffic"
FIX=$SHARE/fixtures
"$RISKCTL" simulate --out "$FIX/events" --events 16 --seed 4 --threads 1 >/dev/null \
  || vm_fail "riskctl simulate failed"
"$RISKCTL" events-to-candump --events "$FIX/events" --out "$FIX/drive.log" >/dev/null \
  || vm_fail "riskctl events-to-candump failed"
model_arg=()
[ -f models/drl-default.rsk ] && model_arg=(--model models/drl-default.rsk)
target/debug/examples/vm_fixtures --out "$FIX" --drive "$FIX/drive.log" "${model_arg[@]}" \
  || vm_fail "writing fixtures failed"
T=$(cat "$FIX/threshold.txt")
# A real radar's DBC and map (Honda Nidec track slots) and its hand-encoded scene.
RADAR=(--dbc can-bridge/maps/dbc/acura_ilx_2016_nidec.dbc --dbc builtin:riskscore --map can-bridge/maps/honda_nidec_radar.toml)
cp can-bridge/maps/dbc/acura_ilx_2016_nidec.dbc can-bridge/maps/honda_nidec_radar.toml \
  can-bridge/maps/scenes/honda_nidec.log "$FIX/"
# Threshold: 90 % of the smallest per-track maximum of the scene, so that every track warns whatever
# the model (the reused slot too, before its new object arrives: the `new_object` release is checked).
RT=$("$BRIDGE" score-log --log "$FIX/honda_nidec.log" --model "$FIX/model.rsk" "${RADAR[@]}" \
  --all-scores 2>/dev/null | awk '{
    if (!match($0, /"track":[0-9]+/)) next; k = substr($0, RSTART + 8, RLENGTH - 8)
    if (!match($0, /"score":[-0-9.e+]+/)) next; v = substr($0, RSTART + 8, RLENGTH - 8) + 0
    if (!(k in m) || v > m[k]) m[k] = v }
    END { first = 1; for (k in m) if (first || m[k] < lo) { lo = m[k]; first = 0 }; print 0.9 * lo }')
echo "$RT" > "$FIX/radar-threshold.txt"

# Two buses: the drive's ego messages on vcan0 and its object messages on vcan1, the project DBC
# split into one file per bus (bound with --dbc BUS=FILE); noise on each bus with the other bus's
# ids and garbage payloads must not reach the engine (unbound, it would corrupt the ego speed).
awk 'BEGIN { RS = ""; ORS = "\n\n" } /^BO_ 25[67] / || !/^(BO_|CM_|VAL_|SIG_VALTYPE_|BA_)/' \
  can-bridge/dbc/riskscore.dbc > "$FIX/ego.dbc"
awk 'BEGIN { RS = ""; ORS = "\n\n" } !/^BO_ 25[67] /' can-bridge/dbc/riskscore.dbc \
  | grep -v '^CM_ BO_ 25[67] ' > "$FIX/objects.dbc"
awk '{ split($3, a, "#"); $2 = (a[1] == "100" || a[1] == "101") ? "vcan0" : "vcan1"; print
  if (a[1] == "100") { print $1 " vcan1 100#FFFFFFFFFFFFFFFF"; print $1 " vcan0 201#FFFFFFFFFFFFFFFF" } }' \
  "$FIX/drive.log" > "$FIX/two-bus.log"
TWOBUS=(--dbc "vcan0=$FIX/ego.dbc" --dbc "vcan1=$FIX/objects.dbc")

vm_kernel
vm_initramfs
cp tests/vm/guest.sh "$SHARE/guest.sh"
vm_say "booting the VM (TCG; timeout ${VM_TIMEOUT}s)"
guest_rc=0
vm_boot "$SHARE" || guest_rc=$?
if [ "$guest_rc" -ne 0 ]; then
  tail -n 30 "$SHARE/console.log" >&2 || true
  [ -f "$SHARE/guest.log" ] && tail -n 30 "$SHARE/guest.log" >&2
  vm_fail "the VM run did not complete (guest exit $guest_rc; logs in ${SHARE#$PWD/})"
fi
O=$SHARE/out
rc() { cat "$O/$1.rc" 2>/dev/null || echo missing; }
has() { grep -q -- "$2" "$O/$1"; }
frames_of() { awk '{print $3}' "$1"; }
events_without_time() { sed -e 's/"t":[-0-9.e+]*,//' "$1"; }
count() { grep -o "$2 [0-9]*\|[0-9]* $2" "$1" | grep -o '[0-9]*' | head -n1; }

# 1. corrupt model
check "corrupt model refused at start (exit 1, reason given)" \
  bash -c "[ \"$(rc corrupt)\" = 1 ] && grep -q 'refused' '$O/corrupt.err'"

# 2. live == offline
"$BRIDGE" score-log --log "$FIX/drive.log" --model "$FIX/model.rsk" --threshold "$T" --min-on-ms 0 \
  --warnings-out "$O/offline-warnings.log" --events-out "$O/offline-events.jsonl" 2> "$O/offline.err" \
  || vm_fail "offline score-log failed: $(tail -n 3 "$O/offline.err")"
check "replay and live bridge exited cleanly" \
  bash -c "[ \"$(rc replay)\" = 0 ] && [ \"$(rc live-bridge)\" = 0 ]"
check "second socket verified every warning frame's CRC and alive counter" \
  bash -c "[ \"$(rc live-monitor)\" = 0 ]"
n_off=$(wc -l < "$O/offline-warnings.log")
n_live=$(wc -l < "$O/live-warnings.log" 2>/dev/null || echo 0)
check "the drive produced warnings (offline: $n_off frames)" test "$n_off" -gt 0
check "live warning frames over vcan == offline (payload, counter and CRC; $n_live vs $n_off)" \
  cmp -s <(frames_of "$O/offline-warnings.log") <(frames_of "$O/live-warnings.log")
# Onsets and score releases come in the same order; a stale release happens when the (compressed,
# 20x) live clock says so, so the events are compared as a set.
check "live warning events == offline (track, score, on/off, reason)" \
  cmp -s <(events_without_time "$O/offline-events.jsonl" | sort) <(events_without_time "$O/live-events.jsonl" | sort)

# 3. faults. The wrong DLC and the out-of-range value are 2 lost frames of 322 lines (0.6%), within
# the default --max-lost 0.01 on purpose: they must be named by line, and the run must pass.
"$BRIDGE" score-log --log "$FIX/faults.log" --model "$FIX/model.rsk" --threshold 1.5 --min-on-ms 0 \
  --warnings-out "$O/faults-offline-warnings.log" 2> "$O/faults-offline.err" >/dev/null \
  || vm_fail "offline score-log of faults.log failed: $(tail -n 3 "$O/faults-offline.err")"
check "offline: the 2 undecodable frames are losses named by line (within --max-lost)" \
  bash -c "[ \"\$(grep -c 'faults.log:[0-9]*: OBJECT_' '$O/faults-offline.err')\" = 2 ] && grep -q ', 2 frames not decodable (within --max-lost 0.01)' '$O/faults-offline.err'"
check "bridge and monitor survived the faults" \
  bash -c "[ \"$(rc faults-bridge)\" = 0 ] && [ \"$(rc faults-monitor)\" = 0 ]"
check "faults counted: wrong DLC + out-of-range (decode errors), error frames incl. bus-off, stale drops" \
  bash -c "grep -q ' 2 decode errors' '$O/faults-bridge.err' && grep -Eq '[1-9][0-9]* stale drops' '$O/faults-bridge.err' && grep -q ' 2 error frames (1 bus-off)' '$O/faults-bridge.err'"
check "kernel filters kept unknown ids and remote frames away from the bridge" \
  bash -c "grep -q ' 0 unknown ids, 0 remote' '$O/faults-bridge.err'"
check "healthy track kept warning through the faults (live == offline)" \
  bash -c "[ -s '$O/faults-warnings.log' ] && cmp -s <(awk '{print \$3}' '$O/faults-offline-warnings.log') <(awk '{print \$3}' '$O/faults-warnings.log')"

# 3b. a real radar's DBC through its map, live
"$BRIDGE" score-log --log "$FIX/honda_nidec.log" --model "$FIX/model.rsk" "${RADAR[@]}" --threshold "$RT" \
  --min-on-ms 0 --warnings-out "$O/radar-offline-warnings.log" --events-out "$O/radar-offline-events.jsonl" \
  2> "$O/radar-offline.err" || vm_fail "offline score-log of the radar scene failed: $(tail -n 3 "$O/radar-offline.err")"
check "real radar map: replay, live bridge and monitor exited cleanly (E2E verified)" \
  bash -c "[ \"$(rc radar-replay)\" = 0 ] && [ \"$(rc radar-bridge)\" = 0 ] && [ \"$(rc radar-monitor)\" = 0 ]"
n_radar=$(wc -l < "$O/radar-offline-warnings.log")
check "real radar map: the scene warns (offline: $n_radar frames at threshold $RT)" test "$n_radar" -gt 0
# The cut-in's lateral speed is derived from its motion over 200 ms of *receive* time: live, the
# replay's timing jitter changes it a little, so scores (and the warning payloads that carry them)
# are not bit-equal to offline. The jitter can also move the first complete motion window of a
# track by one update (`awaiting motion`, 0.2 s), and a warning whose score sits near the threshold
# may end one cycle earlier or later live, so the number and interleaving of periodic warning frames
# are timing, not behaviour; so is the order in which two tracks first warn when offline they do so
# 5 ms apart (seen in CI: offline 0, 5, 9 within 9 ms; live 0, 9, 5). For the same reason a
# track's *last* release may read `score` on one side and `invalid` on the other: its score sat
# within 0.03 of the threshold when the sensor dropped the object, and jitter decided whether it
# dipped under one frame before the drop (seen in CI, 2026-11-26: offline 3.854 -> score, live
# 3.889 -> invalid, threshold 3.878). Behaviour is: the same tracks warn, and each track's own
# on/off events (level, reason, new_object) come in the same order, its final release being a
# release whichever of the two ended it. Likewise a track whose score hovers near the threshold as
# it first warns may blink off and on again on one side only (seen in CI, 2026-11-26: live on at
# 3.691, off at 3.614, on again at 3.756; offline on at 3.756; threshold 3.656): a release by
# score within 0.1 of the threshold that the track's next event undoes is jitter, not compared.
warn_tracks() { awk '{ split($3, a, "#"); print substr(a[2], 5, 2) }' "$1" | sort -u; }
events_by_track() {
  sed -E 's/^(.*"track":([0-9]+).*)$/\2 \1/' "$1" | sort -s -n -k1,1 \
    | awk -v T="$2" -v J=0.1 '
        { line[NR] = $0; track[NR] = $1 }
        END {
          for (i = 1; i <= NR; i++) {
            if (line[i] ~ /"reason":"score"/ && line[i] ~ /"warning":false/ && i < NR \
                && track[i + 1] == track[i] && line[i + 1] ~ /"warning":true/ \
                && match(line[i], /"score":[-0-9.e+]+/)) {
              d = substr(line[i], RSTART + 8, RLENGTH - 8) - T
              if (d < J && -d < J) { i++; continue }
            }
            print line[i]
          }
        }' \
    | sed -e 's/"t":[-0-9.e+]*,//' -e 's/"score":[-0-9.e+]*,//' \
    | awk 'function out(l) { if (l != "") print l }
           { if ($1 != track) { out(final(last)) } else { out(last) } track = $1; last = $0 }
           END { out(final(last)) }
           function final(l) { sub(/"reason":"(score|invalid)"/, "\"reason\":\"end\"", l); return l }'
}
export -f events_by_track
check "real radar map: live warning frames over vcan name the offline tracks" \
  cmp -s <(warn_tracks "$O/radar-offline-warnings.log") <(warn_tracks "$O/radar-warnings.log")
check "real radar map: each track's live warning events == offline (on/off, level, reason incl. new_object)" \
  bash -c "grep -q new_object '$O/radar-offline-events.jsonl' && cmp -s <(events_by_track '$O/radar-offline-events.jsonl' '$RT') <(events_by_track '$O/radar-events.jsonl' '$RT')"
check "real radar map: start-up report names the derived lateral speed" \
  grep -q "object.vel_y: DERIVED" "$O/radar-bridge.err"

# 3c. two buses, live on both interfaces == offline on the same log
"$BRIDGE" score-log --log "$FIX/two-bus.log" --model "$FIX/model.rsk" "${TWOBUS[@]}" --threshold "$T" \
  --min-on-ms 0 --warnings-out "$O/twobus-offline-warnings.log" --warnings-iface vcan1 \
  --events-out "$O/twobus-offline-events.jsonl" 2> "$O/twobus-offline.err" \
  || vm_fail "offline score-log of the two-bus log failed: $(tail -n 3 "$O/twobus-offline.err")"
check "two buses offline: the noise is unknown ids, the warnings are the single-bus log's" \
  bash -c "grep -q ' 0 decode errors, 0 stale drops' '$O/twobus-offline.err' && grep -Eq ' [1-9][0-9]* unknown ids' '$O/twobus-offline.err' && cmp -s <(awk '{print \$3}' '$O/offline-warnings.log') <(awk '{print \$3}' '$O/twobus-offline-warnings.log')"
check "two buses: replay on vcan0 + vcan1, live bridge on both and monitor exited cleanly (E2E verified)" \
  bash -c "[ \"$(rc twobus-replay)\" = 0 ] && [ \"$(rc twobus-bridge)\" = 0 ] && [ \"$(rc twobus-monitor)\" = 0 ]"
check "two buses: one timeline live (0 reordered, 0 decode errors; kernel filters kept the noise away)" \
  bash -c "grep -q ' 0 decode errors' '$O/twobus-bridge.err' && grep -q ' 0 reordered' '$O/twobus-bridge.err' && grep -q ' 0 unknown ids' '$O/twobus-bridge.err'"
check "two buses: live warning frames over vcan1 == offline (payload, counter and CRC)" \
  cmp -s <(frames_of "$O/twobus-offline-warnings.log") <(frames_of "$O/twobus-warnings.log")
check "two buses: live warning events == offline (track, score, on/off, reason)" \
  cmp -s <(events_without_time "$O/twobus-offline-events.jsonl" | sort) <(events_without_time "$O/twobus-events.jsonl" | sort)

# 4./5. interface gone / missing
check "interface deleted under the bridge: exit 2, clear message" \
  bash -c "[ \"$(rc gone)\" = 2 ] && grep -q 'went away' '$O/gone.err'"
check "interface missing at start: exit 2, clear message" \
  bash -c "[ \"$(rc missing)\" = 2 ] && grep -q 'vcan0' '$O/missing.err'"

elapsed=$(( $(date +%s) - started ))
if [ ${#failures[@]} -gt 0 ]; then
  vm_say "logs: ${SHARE#$PWD/}/out/ (guest: ${SHARE#$PWD/}/guest.log)"
  vm_fail "${#failures[@]} vcan check(s) failed: ${failures[*]}"
fi
vm_say "all vcan checks passed in ${elapsed}s ($n_live warning frames live == offline)"
