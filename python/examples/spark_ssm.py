#!/usr/bin/env python3
"""Score a Parquet folder of ego/partner pairs into a Parquet folder with Spark.

    python spark_ssm.py --input pairs/ --output pairs_ssm/ [--model models/drl-default.rsk]
                        [--master local[2]]

Every input column is kept; the 17 columns of `riskctl ssm` are appended (box_distance, ttc2d,
tadv, ei, f_l_ego ... f_s; null where a row cannot be scored), and with --model a `risk` column
scored exactly as on the ECU. Runs on any Spark >= 3.5 whose executors have `riskscore` installed
(pip install riskscore-*.whl); --master local[N] runs on this machine (set PYSPARK_PYTHON to
the interpreter that has riskscore when it is a venv's). See docs/scale.md.
"""
import argparse
import sys
import time

from pyspark.sql import SparkSession

import riskscore.spark as rs


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--input", required=True, help="Parquet file or folder of pairs")
    parser.add_argument("--output", required=True, help="Parquet folder to write (must not exist)")
    parser.add_argument("--model", help="model blob (.rsk) to add a `risk` column")
    parser.add_argument("--master", default=None, help="Spark master, e.g. local[2] (default: spark-submit's)")
    args = parser.parse_args()

    builder = SparkSession.builder.appName("riskscore-ssm")
    if args.master:
        builder = builder.master(args.master)
    spark = builder.getOrCreate()
    pairs = spark.read.parquet(args.input)
    out = rs.ssm(pairs)
    if args.model:
        out = rs.score(out, args.model)
    started = time.perf_counter()
    out.write.mode("errorifexists").parquet(args.output)
    seconds = time.perf_counter() - started
    rows = spark.read.parquet(args.output).count()
    print(f"{rows} rows in {seconds:.1f} s ({rows / seconds:,.0f} rows/s) -> {args.output}", file=sys.stderr)
    spark.stop()
    return 0


if __name__ == "__main__":
    sys.exit(main())
