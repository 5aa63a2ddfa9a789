#!/usr/bin/env bash
# Whole-process benchmark of `riskctl ssm` (and its Parquet paths): rows/s, CPU and peak memory.
#
#   scripts/bench-ssm.sh [PAIRS.csv]
#
# Without an argument the input is built from real freeway trajectories: 1,000,000 ego/partner
# pairs from the NGSIM US-101 CommonRoad scenarios (scripts/ngsim_pairs.py; set NGSIM_DIR, default
# ../shared/data/ngsim-us101). Files go to ${BENCH_DIR:-/tmp/riskscore-bench}. Needs GNU time.
#
# Each line gives the load average just before the run (other processes on the machine slow the
# wall clock; CPU seconds are the steadier figure) and the rows/s ratio to the csv -> csv run of
# the same invocation. "pairs.parquet" is the input pairs themselves as Parquet (23 columns; needs
# pyarrow: .cache/pyenv from scripts/setup.sh, or $PYTHON); "out.parquet" is the scored csv ->
# parquet output (40 columns), so parquet -> parquet on it writes 57 columns.
set -euo pipefail
cd "$(dirname "$0")/.."
# shellcheck source=scripts/bench-pairs.sh
. scripts/bench-pairs.sh
cargo build --quiet --release -p host-tools --bin riskctl
riskctl=target/release/riskctl
rows=$(($(wc -l < "$input") - 1))

# One run: label, then riskctl ssm arguments. Prints wall s, CPU s, rows/s and max RSS.
# The output of an earlier run is deleted first: replacing a 330 MB file makes the file system
# free its blocks inside the timed rename (0.2-0.5 s on this ext4 mount), which is not our work.
run() {
    local label=$1
    shift
    local log="$dir/time.log"
    local out=${*: -1}
    [ -f "$out" ] && rm -f "$out" && sync
    local load
    load=$(cut -d' ' -f1 /proc/loadavg)
    /usr/bin/time -f '%e %U %S %M' -o "$log" "$riskctl" ssm "$@" 2>/dev/null
    read -r wall user sys rss < "$log"
    [ -n "${csv_wall:-}" ] || csv_wall=$wall
    awk -v l="$label" -v w="$wall" -v u="$user" -v s="$sys" -v m="$rss" -v n="$rows" \
        -v c="$csv_wall" -v a="$load" 'BEGIN {
        printf "%-30s %6.2f s wall %6.2f s CPU %10.0f rows/s %5.2fx csv %7.1f MB RSS  load %s\n",
               l, w, u + s, n / w, c / w, m / 1024, a }'
}

py=${PYTHON:-python3}
[ -x .cache/pyenv/bin/python ] && [ -z "${PYTHON:-}" ] && py=.cache/pyenv/bin/python
pairs_parquet=$dir/pairs.parquet
if [ ! -f "$pairs_parquet" ] && "$py" -c 'import pyarrow' 2>/dev/null; then
    # Row groups of 131,072 rows, as riskscore writes them (pyarrow's default is one of 1 M).
    "$py" -c 'import sys, pyarrow.csv as c, pyarrow.parquet as p
p.write_table(c.read_csv(sys.argv[1]), sys.argv[2], row_group_size=131072)' "$input" "$pairs_parquet"
fi

echo "input: $input ($rows rows, $(du -h "$input" | cut -f1)), $(nproc) cores, load $(cut -d' ' -f1-3 /proc/loadavg)"
cat "$input" > /dev/null # page cache
csv_wall=
run "csv -> csv" -i "$input" -o "$dir/out.csv"
run "csv -> csv (1 thread)" -i "$input" -o "$dir/out1.csv" --threads 1
run "csv -> /dev/null" -i "$input" -o /dev/null
run "csv -> parquet" -i "$input" -o "$dir/out.parquet"
run "csv -> parquet (1 thread)" -i "$input" -o "$dir/out1.parquet" --threads 1
if [ -f "$pairs_parquet" ]; then
    cat "$pairs_parquet" > /dev/null
    run "pairs.parquet -> parquet" -i "$pairs_parquet" -o "$dir/pairs_out.parquet"
    run "pairs.parquet -> parquet (1 th.)" -i "$pairs_parquet" -o "$dir/pairs_out1.parquet" --threads 1
    run "pairs.parquet -> csv" -i "$pairs_parquet" -o "$dir/pairs_out.csv"
    cmp -s "$dir/pairs_out.parquet" "$dir/pairs_out1.parquet" &&
        echo "pairs.parquet -> parquet: 1-thread and parallel outputs are identical"
else
    echo "(no pyarrow: pairs.parquet runs skipped)"
fi
run "out.parquet -> parquet" -i "$dir/out.parquet" -o "$dir/out2.parquet"
run "out.parquet -> csv" -i "$dir/out.parquet" -o "$dir/out3.csv"
cmp -s "$dir/out.csv" "$dir/out1.csv" && echo "csv -> csv: 1-thread and parallel outputs are identical"
cmp -s "$dir/out.parquet" "$dir/out1.parquet" &&
    echo "csv -> parquet: 1-thread and parallel outputs are identical"
