"""riskscore on Spark: the same Arrow kernels over a DataFrame with ``mapInArrow``.

Each executor gets Arrow record batches of its partition and hands them to the Rust kernels
without a per-row Python step; the model blob is broadcast once. Needs pyspark >= 3.5 (and a Java
17 runtime); the executors need this package installed.

    from pyspark.sql import SparkSession
    import riskscore.spark as rs

    spark = SparkSession.builder.master("local[2]").getOrCreate()
    pairs = spark.read.parquet("pairs/")                  # the 18 pair columns, any others kept
    rs.ssm(pairs).write.parquet("pairs_ssm/")             # + box_distance ... f_s (float, null = bad row)
    rs.score(pairs, "models/drl-default.rsk").write.parquet("pairs_risk/")   # + risk
    rs.score(pairs, riskscore.Model.load("models/drl-default.rsk"))          # or a loaded Model

Bad rows are null in the computed columns (as :func:`riskscore.ssm`; executors' warnings are not
shown on the driver, so count the nulls). A missing or non-numeric column, or an input that
already has a column the call appends (``ssm`` run twice), raises ``ColumnError`` on the driver
before any job runs.
"""
from __future__ import annotations

import os
from typing import Any, Iterator, Optional, Union

import pyarrow as pa

import riskscore

from ._inputs import as_table

_PAIR_COLUMNS = [
    f"{f}_{side}"
    for side in ("i", "j")
    for f in ("x", "y", "vx", "vy", "hx", "hy", "acc", "length", "width")
]


def _check_columns(df: Any) -> None:
    """Fail on the driver, naming the column, before a job starts."""
    from pyspark.sql import types as T

    if not (hasattr(df, "mapInArrow") and hasattr(df, "schema")):
        # A pandas or polars frame would fail with "'DataFrame' object has no attribute 'schema'".
        raise TypeError(
            f"expected a Spark DataFrame, not {type(df).__module__}.{type(df).__name__} "
            "(riskscore.ssm and riskscore.Model.score take pandas, polars and pyarrow tables)"
        )

    numeric = (T.DoubleType, T.FloatType, T.LongType, T.IntegerType)
    by_name = {f.name.lower(): f for f in df.schema.fields}
    missing = [c for c in _PAIR_COLUMNS if c not in by_name]
    if missing:
        raise riskscore.ColumnError(f"missing pair column(s): {', '.join(missing)}")
    for c in _PAIR_COLUMNS:
        if not isinstance(by_name[c].dataType, numeric):
            raise riskscore.ColumnError(
                f"column {by_name[c].name}: type {by_name[c].dataType.simpleString()} is not "
                "supported: a pair column must be double, float, bigint or int (cast it)"
            )


def _with_float_columns(df: Any, names: list) -> Any:
    """``df``'s schema with the FloatType columns ``names`` appended; a name ``df`` already has
    is refused on the driver (Spark would fail inside the job, or on writing)."""
    from pyspark.sql import types as T

    taken = {f.name.lower(): f.name for f in df.schema.fields}
    clash = [taken[n.lower()] for n in names if n.lower() in taken]
    if clash:
        raise riskscore.ColumnError(
            f"the input already has column(s) {', '.join(clash)} that this call appends "
            "(drop or rename them first)"
        )

    fields = list(df.schema.fields) + [T.StructField(n, T.FloatType(), True) for n in names]
    return T.StructType(fields)


def ssm(df: Any) -> Any:
    """``df`` with the 17 computed columns of :func:`riskscore.ssm` appended (FloatType,
    nullable), row for row, computed by the Rust kernels on the executors."""
    _check_columns(df)
    names = riskscore.computed_columns()

    def compute(batches: Iterator[pa.RecordBatch]) -> Iterator[pa.RecordBatch]:
        import warnings

        from riskscore import _riskscore

        for batch in batches:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                table, _bad, _count = _riskscore.ssm(as_table(batch), True)
            yield from table.to_batches()

    return df.mapInArrow(compute, _with_float_columns(df, names))


def _model_blob(model: Any, argument: str = "model") -> bytes:
    """What the executors receive for ``model``: the validated blob's bytes. A path is read and
    validated here, on the driver (``OSError`` or ``ModelError`` naming the file); a loaded
    :class:`riskscore.Model` gives the blob it holds (also one made with ``from_bytes`` or
    unpickled), not a re-read of its file, as :func:`riskscore.evaluate` does."""
    if isinstance(model, riskscore.Model):
        return model.to_bytes()
    if isinstance(model, (str, os.PathLike)):
        return riskscore.Model.load(model).to_bytes()
    raise TypeError(
        f"{argument}: expected a path to a model blob (.rsk) or a riskscore.Model, not "
        f"{type(model).__name__}"
    )


_NO_MODEL: Any = object()


def score(
    df: Any,
    model: Union[str, "os.PathLike[str]", "riskscore.Model"] = _NO_MODEL,
    column: str = "risk",
    spark: Optional[Any] = None,
    *,
    model_path: Union[str, "os.PathLike[str]", "riskscore.Model"] = _NO_MODEL,
) -> Any:
    """``df`` with one FloatType column (``column``) of the model's risk score per row, null where
    the row cannot be scored. ``model`` is a path to a model blob or a loaded
    :class:`riskscore.Model` (its held blob is used, as by :func:`riskscore.evaluate`);
    ``model_path=`` is the former name of the argument and still accepted. The blob is read
    (or taken from the Model) on the driver, validated, and broadcast once as its bytes."""
    if model_path is not _NO_MODEL:
        if model is not _NO_MODEL:
            raise TypeError("score: pass the model once, as model or as model_path, not both")
        model, argument = model_path, "model_path"
    else:
        argument = "model"
    if model is _NO_MODEL:
        raise TypeError("score: missing the model (a path to a .rsk blob or a riskscore.Model)")
    _check_columns(df)
    blob_bytes = _model_blob(model, argument)
    session = spark or df.sparkSession
    blob = session.sparkContext.broadcast(blob_bytes)

    def compute(batches: Iterator[pa.RecordBatch]) -> Iterator[pa.RecordBatch]:
        import numpy as np

        from riskscore import _riskscore

        scorer = _riskscore.Model.from_bytes(blob.value)  # once per partition, not per row
        for batch in batches:
            scores, _bad, _count = scorer._score(as_table(batch))
            values = scores.to_numpy(zero_copy_only=True)
            risk = pa.array(values, mask=np.isnan(values))
            columns = batch.columns + [risk]
            yield pa.RecordBatch.from_arrays(columns, names=batch.schema.names + [column])

    return df.mapInArrow(compute, _with_float_columns(df, [column]))
