#!/bin/sh
# Runs inside the VM for tests/vm/bench.sh: full-load replay with the live bridge and the monitor.
set -u
B=./bin/can-bridge
F=./fixtures
O=./out
mkdir -p "$O"
wait_for() {
  i=0
  while ! grep -q "$2" "$1" 2>/dev/null; do
    i=$((i + 1)); [ $i -gt 300 ] && return 1; sleep 0.1
  done
}
# Let the bridge's 16 MiB receive buffer take effect (the default cap is ~208 KiB).
echo 67108864 > /proc/sys/net/core/rmem_max
ip link add dev vcan0 type vcan && ip link set up vcan0 || exit 10
$B monitor --iface vcan0 --idle-exit 3 2> "$O/monitor.err" &
MON=$!
$B live --iface vcan0 --model "$F/model.rsk" --threshold 1.5 --min-on-ms 0 --no-status \
   --idle-exit 3 --events-out /dev/null 2> "$O/bridge.err" &
BR=$!
wait_for "$O/monitor.err" listening && wait_for "$O/bridge.err" listening || exit 11
$B replay --log "$F/bench.log" --iface vcan0 --rate 1.0 2> "$O/replay.err"
wait $BR; echo $? > "$O/bridge.rc"
wait $MON; echo $? > "$O/monitor.rc"
exit 0
