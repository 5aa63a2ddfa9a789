"""riskscore.spark in local[2] on over a million real rows: identical to `riskctl ssm`.

The rows are the shipped NGSIM US-101 frames repeated to $RISKSCORE_SPARK_ROWS (default
1,000,000; every row a real pair),
written as a Parquet folder; Spark reads it, runs riskscore.spark.ssm / score and writes Parquet,
and every value is compared with riskctl's output for the same rows.
"""
import os
import sys
import time

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest

import riskscore
from conftest import MODELS, PAIR_COLUMNS, rows_equal_bitwise

# scripts/test.sh runs the dev-profile wheel (unoptimised core) and a debug riskctl, so it asks
# for fewer rows; scripts/bench-python.sh runs the full million on the release build.
ROWS = int(os.environ.get("RISKSCORE_SPARK_ROWS", 1_000_000))


@pytest.fixture(scope="module")
def spark():
    from pyspark.sql import SparkSession

    # The Python workers must import the riskscore under test: run them on this interpreter.
    os.environ["PYSPARK_PYTHON"] = os.environ["PYSPARK_DRIVER_PYTHON"] = sys.executable
    session = (
        SparkSession.builder.master("local[2]")
        .appName("riskscore-tests")
        .config("spark.ui.enabled", "false")
        .config("spark.sql.shuffle.partitions", "2")
        .config("spark.driver.memory", "1g")
        .getOrCreate()
    )
    yield session
    session.stop()


@pytest.fixture(scope="module")
def million_pairs(ngsim_frames, tmp_path_factory):
    """A Parquet folder of >= 1 M real pairs with a row id, in four files."""
    base = ngsim_frames.select(PAIR_COLUMNS).combine_chunks()
    repeats = -(-ROWS // base.num_rows)
    table = pa.concat_tables([base] * repeats).combine_chunks()
    table = table.append_column("row_id", pa.array(np.arange(table.num_rows, dtype=np.int64)))
    folder = tmp_path_factory.mktemp("pairs") / "in"
    folder.mkdir()
    step = -(-table.num_rows // 4)
    for k in range(4):
        pq.write_table(table.slice(k * step, step), folder / f"part-{k}.parquet", row_group_size=65536)
    return folder, table


def test_spark_ssm_is_identical_to_riskctl(spark, million_pairs, riskctl, tmp_path):
    import riskscore.spark as rs

    folder, table = million_pairs
    assert table.num_rows >= ROWS
    started = time.perf_counter()
    rs.ssm(spark.read.parquet(str(folder))).write.parquet(str(tmp_path / "out"))
    seconds = time.perf_counter() - started
    print(f"\nspark local[2] ssm: {table.num_rows} rows in {seconds:.1f} s, "
          f"{table.num_rows / seconds / 1e6:.2f} M rows/s (read, score, write Parquet)")
    ours = pq.read_table(tmp_path / "out").sort_by("row_id")
    assert ours.num_rows == table.num_rows
    assert np.array_equal(ours.column("row_id").to_numpy(), table.column("row_id").to_numpy())

    pq.write_table(table, tmp_path / "all.parquet")
    riskctl("ssm", "--input", tmp_path / "all.parquet", "--output", tmp_path / "cli.parquet")
    expected = pq.read_table(tmp_path / "cli.parquet")
    names = riskscore.computed_columns()
    rows_equal_bitwise(ours.select(names), expected.select(names))


def test_spark_score_matches_the_model(spark, million_pairs, tmp_path):
    import riskscore.spark as rs

    folder, table = million_pairs
    part = spark.read.parquet(str(folder)).limit(200_000)
    rs.score(part, str(MODELS / "drl-default.rsk")).write.parquet(str(tmp_path / "risk"))
    scored = pq.read_table(tmp_path / "risk").sort_by("row_id")
    ids = scored.column("row_id").to_numpy()
    expected = riskscore.Model.load(MODELS / "drl-default.rsk").score(table.take(ids))
    got = scored.column("risk").to_numpy().astype(np.float32)
    assert np.array_equal(got.view(np.uint32), expected.view(np.uint32))


def test_spark_score_takes_a_loaded_model(spark, million_pairs, tmp_path):
    """A Model (here one with no file behind it, as unpickled or from_bytes) is scored from the
    blob it holds, shipped to the executors as its bytes."""
    import riskscore.spark as rs

    folder, table = million_pairs
    model = riskscore.Model.from_bytes((MODELS / "drl-default.rsk").read_bytes())
    assert model.path is None
    part = spark.read.parquet(str(folder)).limit(20_000)
    rs.score(part, model).write.parquet(str(tmp_path / "risk"))
    scored = pq.read_table(tmp_path / "risk").sort_by("row_id")
    expected = model.score(table.take(scored.column("row_id").to_numpy()))
    got = scored.column("risk").to_numpy().astype(np.float32)
    assert np.array_equal(got.view(np.uint32), expected.view(np.uint32))


def test_what_spark_score_ships_to_the_executors(tmp_path):
    """No Spark needed: the model argument becomes the validated blob's bytes, from a path or
    from a loaded Model (the blob it holds, not a re-read of its file, which may since have
    changed); anything else, or a file that is not a blob, is refused naming it."""
    from riskscore.spark import _model_blob, score

    path = tmp_path / "model.rsk"
    blob = (MODELS / "drl-default.rsk").read_bytes()
    path.write_bytes(blob)
    loaded = riskscore.Model.load(path)
    assert _model_blob(path) == _model_blob(str(path)) == blob
    path.write_bytes((MODELS / "msra-default.rsk").read_bytes())
    assert _model_blob(loaded) == blob
    assert _model_blob(riskscore.Model.from_bytes(blob)) == blob
    assert riskscore.Model.from_bytes(_model_blob(loaded)).info == loaded.info
    with pytest.raises(TypeError, match="model: expected a path to a model blob .* or a riskscore.Model, not bytes"):
        _model_blob(blob)
    with pytest.raises(TypeError, match="model_path: .* not int"):
        _model_blob(3, "model_path")
    with pytest.raises(FileNotFoundError, match="missing.rsk"):
        _model_blob(tmp_path / "missing.rsk")
    (tmp_path / "junk.rsk").write_bytes(b"not a model")
    with pytest.raises(riskscore.ModelError, match="junk.rsk"):
        _model_blob(tmp_path / "junk.rsk")
    # The argument's former name still works as a keyword; the model is needed once.
    with pytest.raises(TypeError, match="not both"):
        score(None, path, model_path=path)
    with pytest.raises(TypeError, match="missing the model"):
        score(None)


def test_spark_refuses_a_missing_column_on_the_driver(spark, million_pairs):
    import riskscore.spark as rs

    folder, _table = million_pairs
    with pytest.raises(riskscore.ColumnError, match="hx_j"):
        rs.ssm(spark.read.parquet(str(folder)).drop("hx_j"))


def test_spark_refuses_an_input_that_has_the_output_columns(spark, million_pairs):
    """ssm over its own output (or score into an existing column) fails on the driver, naming
    the column, not inside the job with an Arrow stack trace."""
    import riskscore.spark as rs

    folder, _table = million_pairs
    df = spark.read.parquet(str(folder))
    with pytest.raises(riskscore.ColumnError, match="already has column.*box_distance"):
        rs.ssm(rs.ssm(df))
    with pytest.raises(riskscore.ColumnError, match="already has column.*RISK"):
        rs.score(df.withColumn("RISK", df.x_i), str(MODELS / "drl-default.rsk"))


def test_a_local_frame_is_pointed_at_the_local_api(golden_pairs):
    """A pandas frame handed to riskscore.spark used to fail with "'DataFrame' object has no
    attribute 'schema'"; no Spark session is needed to say so."""
    import riskscore.spark as rs

    frame = golden_pairs.to_pandas()
    for call in (lambda: rs.ssm(frame), lambda: rs.score(frame, MODELS / "drl-default.rsk")):
        with pytest.raises(TypeError, match=r"expected a Spark DataFrame, not pandas\..*DataFrame "
                                            r"\(riskscore\.ssm and riskscore\.Model\.score take"):
            call()
