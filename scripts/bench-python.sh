#!/usr/bin/env bash
# Throughput of the Python package: `riskscore.ssm` and `Model.score` on an in-memory Arrow table
# of 1,000,000 real ego/partner pairs (NGSIM US-101, scripts/ngsim_pairs.py), release build, with
# all cores and with one, against `riskctl ssm` CSV -> CSV on the same rows in the same run.
#
#   scripts/bench-python.sh [PAIRS.csv]
#
# Set NGSIM_DIR (default ../shared/data/ngsim-us101); files go to ${BENCH_DIR:-/tmp/riskscore-bench}.
# The release wheel is installed into .cache/pyenv (scripts/setup.sh python makes it).
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh python
# shellcheck source=scripts/bench-pairs.sh
. scripts/bench-pairs.sh
py=.cache/pyenv/bin/python
rm -f target/wheels-release/riskscore-*.whl
.cache/pyenv/bin/maturin build --quiet --release --manifest-path python/Cargo.toml \
    --interpreter "$py" --out target/wheels-release
"$py" -m pip install --quiet --disable-pip-version-check --force-reinstall --no-deps \
    target/wheels-release/riskscore-*.whl
# $RISKCTL: an already built release riskctl of the same tree (skips building it here).
riskctl=${RISKCTL:-target/release/riskctl}
[ -n "${RISKCTL:-}" ] || cargo build --quiet --release -p host-tools --bin riskctl

echo "input: $input ($(($(wc -l < "$input") - 1)) rows), $(nproc) cores, load $(cut -d' ' -f1-3 /proc/loadavg)"
# riskctl's CSV path in the same run, the reference the Python figures are read against.
start=$(date +%s.%N)
"$riskctl" ssm -i "$input" -o "$dir/bench-python-out.csv" 2>/dev/null
end=$(date +%s.%N)
rm -f "$dir/bench-python-out.csv"
export CSV_SECONDS=$(echo "$end - $start" | bc -l)

"$py" - "$input" <<'PY'
import os, subprocess, sys, time

import pyarrow.csv as pcsv

import riskscore

path = sys.argv[1]
table = pcsv.read_csv(path)
rows = table.num_rows
csv_rate = rows / float(os.environ["CSV_SECONDS"])


def best(label, fn, runs=5):
    times = []
    for _ in range(runs):
        t = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t)
    rate = rows / min(times)
    print(f"{label:44s} {min(times):6.3f} s best of {runs} {rate / 1e6:6.2f} M rows/s "
          f"({rate / csv_rate:4.2f}x riskctl ssm csv -> csv)")
    return rate


print(f"{'riskctl ssm csv -> csv (reference)':44s} {rows / csv_rate:6.3f} s           "
      f"{csv_rate / 1e6:6.2f} M rows/s")
threads = os.environ.get("RAYON_NUM_THREADS", str(os.cpu_count()))
best(f"riskscore.ssm, {threads} threads", lambda: riskscore.ssm(table))
best(f"riskscore.ssm(keep_input=True), {threads} threads",
     lambda: riskscore.ssm(table, keep_input=True))
model = riskscore.Model.load("models/drl-default.rsk")
best(f"Model.score DRL int8, {threads} threads", lambda: model.score(table))
if "RAYON_NUM_THREADS" not in os.environ:
    # One core, in a child (rayon's pool is sized once per process).
    subprocess.run([sys.executable, "-c", f"""
import time, pyarrow.csv as pcsv, riskscore
t = pcsv.read_csv({path!r}); n = t.num_rows
best = min((lambda s: (riskscore.ssm(t), time.perf_counter() - s)[1])(time.perf_counter()) for _ in range(3))
print(f"{{'riskscore.ssm, 1 thread':44s}} {{best:6.3f}} s best of 3 {{n / best / 1e6:6.2f}} M rows/s")
"""], env={**os.environ, "RAYON_NUM_THREADS": "1"}, check=True)
PY

# Spark local[2] on the same machine: the million-row parity run of python/tests/test_spark.py
# (real pairs -> Parquet folder -> riskscore.spark.ssm -> Parquet, compared with riskctl ssm
# value for value), printing its throughput. Needs pyspark and Java 17 (scripts/setup.sh python).
RISKSCORE_SPARK_ROWS=1000000 RISKCTL=$riskctl "$py" -m pytest -q -s -p no:cacheprovider \
    --rootdir python/tests python/tests/test_spark.py -k identical 2>&1 | grep -E "spark local|passed|failed|Error"
