#!/usr/bin/env bash
# Whole-process benchmark of `riskctl evaluate` and `riskctl score` on a fleet-sized event folder:
# frames/s, CPU per frame and peak memory (GNU time).
#
#   scripts/bench-evaluate.sh [EVENT_DIR]
#
# Without an argument the folder is simulated: 100,000 events (about 10.7 M frames, 1.6 GB) with
# `riskctl simulate --events 100000`, into ${BENCH_DIR:-/tmp/riskscore-bench}/events100k (not
# committed; delete it when done). Models: the shipped DRL, MSRA, SSRA and GSSM blobs, plus the
# three baselines evaluate adds. Set RISKCTL_BEFORE to another riskctl binary to compare its
# `evaluate --json`, `evaluate --out` (tables, ROC and PR figures; the trajectory figure may differ
# within the stated tolerance of the percentile summary, see host-tools/src/eval/sketch.rs) and
# `score` outputs byte for byte, and its time and memory.
set -euo pipefail
cd "$(dirname "$0")/.."
dir=${BENCH_DIR:-/tmp/riskscore-bench}
mkdir -p "$dir"
cargo build --quiet --release -p host-tools --bin riskctl
riskctl=target/release/riskctl
events=${1:-$dir/events100k}
if [ ! -f "$events/frames.csv" ]; then
    "$riskctl" simulate --out "$events" --events 100000 > /dev/null
fi
frames=$(($(wc -l < "$events/frames.csv") - 1))
models=(--model models/drl-default.rsk --model models/msra-default.rsk
        --model models/ssra-default.rsk --model models/gssm-default.rsk)

# One run: label, binary, then riskctl arguments; stdout and stderr to $dir/<label>.{out,err}.
run() {
    local label=$1 bin=$2
    shift 2
    local log="$dir/time.log"
    /usr/bin/time -f '%e %U %S %M' -o "$log" "$bin" "$@" > "$dir/$label.out" 2> "$dir/$label.err" \
        || { echo "$label failed:"; tail -n 3 "$dir/$label.err"; return 1; }
    read -r wall user sys rss < "$log"
    awk -v l="$label" -v w="$wall" -v u="$user" -v s="$sys" -v m="$rss" -v n="$frames" 'BEGIN {
        printf "%-26s %7.2f s wall %7.2f s CPU %9.0f frames/s wall %6.2f us CPU/frame %8.1f MB max RSS\n",
               l, w, u + s, n / w, 1e6 * (u + s) / n, m / 1024 }'
}

echo "events: $events ($(($(wc -l < "$events/events.csv") - 1)) events, $frames frames," \
     "$(du -h "$events/frames.csv" | cut -f1)), $(nproc) cores, load $(cut -d' ' -f1-3 /proc/loadavg)"
cat "$events/frames.csv" > /dev/null # page cache
run evaluate "$riskctl" evaluate "${models[@]}" --events "$events" --json
rm -rf "$dir/out"
run evaluate-out "$riskctl" evaluate "${models[@]}" --events "$events" --out "$dir/out"
run score "$riskctl" score "${models[@]}" --events "$events" --out "$dir/scores.csv"
run score-parquet "$riskctl" score "${models[@]}" --events "$events" --out "$dir/scores.parquet"
if [ -n "${RISKCTL_BEFORE:-}" ]; then
    run evaluate-before "$RISKCTL_BEFORE" evaluate "${models[@]}" --events "$events" --json
    cmp "$dir/evaluate.out" "$dir/evaluate-before.out" && echo "evaluate --json: identical to $RISKCTL_BEFORE"
    rm -rf "$dir/out-before"
    run evaluate-out-before "$RISKCTL_BEFORE" evaluate "${models[@]}" --events "$events" --out "$dir/out-before"
    for f in results.csv results.json results.md curves.csv roc.svg roc.png pr.svg pr.png \
             trajectories.svg trajectories.png; do
        if cmp -s "$dir/out/$f" "$dir/out-before/$f"; then
            echo "evaluate --out $f: identical"
        else
            echo "evaluate --out $f: DIFFERS from $RISKCTL_BEFORE"
        fi
    done
    run score-before "$RISKCTL_BEFORE" score "${models[@]}" --events "$events" --out "$dir/scores-before.csv"
    cmp "$dir/scores.csv" "$dir/scores-before.csv" && echo "score csv: identical to $RISKCTL_BEFORE"
fi
rm -f "$dir/scores.csv" "$dir/scores.parquet" "$dir/scores-before.csv"
rm -rf "$dir/out" "$dir/out-before"
