"""riskscore.ssm: parity with `riskctl ssm`, input kinds, bad rows, errors, zero copy."""
import re
import time
import warnings

import numpy as np
import pyarrow as pa
import pyarrow.csv as pcsv
import pyarrow.parquet as pq
import pytest

import riskscore
from conftest import MODELS, PAIR_COLUMNS, rows_equal_bitwise


def riskctl_ssm(riskctl, tmp_path, table):
    """`riskctl ssm` on `table` written as Parquet: its 17 computed columns."""
    source, result = tmp_path / "pairs.parquet", tmp_path / "pairs_ssm.parquet"
    pq.write_table(table, source)
    riskctl("ssm", "--input", source, "--output", result)
    return pq.read_table(result).select(riskscore.computed_columns())


def test_golden_cases_match_riskctl_bit_for_bit(riskctl, tmp_path, golden_pairs):
    ours = riskscore.ssm(golden_pairs)
    assert ours.column_names == riskscore.computed_columns()
    assert len(ours.column_names) == 17
    rows_equal_bitwise(ours, riskctl_ssm(riskctl, tmp_path, golden_pairs))


def test_real_ngsim_frames_match_riskctl_bit_for_bit(riskctl, tmp_path, ngsim_frames):
    pairs = ngsim_frames.select(PAIR_COLUMNS)
    assert pairs.num_rows > 10_000
    ours = riskscore.ssm(pairs)
    assert ours.column("ttc2d").null_count == 0
    rows_equal_bitwise(ours, riskctl_ssm(riskctl, tmp_path, pairs))


def test_every_input_kind_gives_the_same_table(golden_pairs):
    import pandas as pd
    import polars as pl

    expected = riskscore.ssm(golden_pairs)
    frame = golden_pairs.to_pandas()
    upper = frame.rename(columns=str.upper)[list(reversed(frame.columns.str.upper()))]
    kinds = {
        "record batch": golden_pairs.combine_chunks().to_batches()[0],
        "pandas": frame,
        "pandas, upper case, reversed": upper,
        "polars": pl.from_arrow(golden_pairs),
        "polars lazy": pl.from_arrow(golden_pairs).lazy(),
        "dict of numpy": {c: golden_pairs.column(c).to_numpy() for c in PAIR_COLUMNS},
    }
    assert isinstance(frame, pd.DataFrame)
    for kind, data in kinds.items():
        rows_equal_bitwise(riskscore.ssm(data), expected)


def test_integer_and_float32_columns_are_the_same_numbers(golden_pairs):
    at = PAIR_COLUMNS.index("x_j")
    whole = np.round(golden_pairs.column("x_j").to_numpy())
    as_f64 = golden_pairs.set_column(at, "x_j", pa.array(whole))
    expected = riskscore.ssm(as_f64)
    for kind in (pa.int64(), pa.int32(), pa.float32()):
        rows_equal_bitwise(riskscore.ssm(as_f64.set_column(at, "x_j", pa.array(whole).cast(kind))), expected)


def test_parquet_and_csv_paths_are_read(tmp_path, golden_pairs):
    import pyarrow.csv as pcsv

    pq.write_table(golden_pairs, tmp_path / "p.parquet")
    pcsv.write_csv(golden_pairs, tmp_path / "p.csv")
    expected = riskscore.ssm(golden_pairs)
    rows_equal_bitwise(riskscore.ssm(tmp_path / "p.parquet"), expected)
    rows_equal_bitwise(riskscore.ssm(str(tmp_path / "p.csv")), expected)


def with_bad_rows(table):
    """`table` with a NaN vy_j in row 3 and a zero heading (hx_i = hy_i = 0) in row 5."""
    vy = table.column("vy_j").to_numpy().copy()
    vy[3] = np.nan
    hx = table.column("hx_i").to_numpy().copy()
    hy = table.column("hy_i").to_numpy().copy()
    hx[5] = hy[5] = 0.0
    out = table.set_column(table.column_names.index("vy_j"), "vy_j", pa.array(vy))
    out = out.set_column(out.column_names.index("hx_i"), "hx_i", pa.array(hx))
    return out.set_column(out.column_names.index("hy_i"), "hy_i", pa.array(hy))


def test_bad_rows_are_null_named_and_the_rest_is_kept(golden_pairs):
    bad = with_bad_rows(golden_pairs)
    with pytest.warns(riskscore.BadRowWarning, match=r"2 row\(s\).*row 3 column vy_j.*row 5 column hx_i"):
        out = riskscore.ssm(bad)
    assert out.num_rows == golden_pairs.num_rows
    good = riskscore.ssm(golden_pairs)
    for name in out.column_names:
        column = out.column(name)
        assert column.is_null().to_pylist() == [k in (3, 5) for k in range(out.num_rows)]
    keep = pa.array([k not in (3, 5) for k in range(out.num_rows)])
    rows_equal_bitwise(out.filter(keep), good.filter(keep))


def test_strict_raises_on_the_first_bad_row(golden_pairs):
    with pytest.raises(riskscore.BadRowError) as caught:
        riskscore.ssm(with_bad_rows(golden_pairs), strict=True)
    e = caught.value
    assert (e.row, e.column, e.count) == (3, "vy_j", 2)
    assert "not finite" in e.problem and isinstance(e, ValueError)


def test_null_and_infinite_values_name_their_row():
    table = pa.table({c: pa.array([1.0, 1.0, 1.0]) for c in PAIR_COLUMNS})
    table = table.set_column(PAIR_COLUMNS.index("acc_i"), "acc_i", pa.array([1.0, None, np.inf]))
    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always")
        out = riskscore.ssm(table)
    assert out.column("ei").is_null().to_pylist() == [False, True, True]
    message = str(seen[0].message)
    assert "row 1 column acc_i: missing field" in message and "row 2 column acc_i" in message


def test_missing_and_non_numeric_columns_are_named(golden_pairs):
    with pytest.raises(riskscore.ColumnError, match="width_j"):
        riskscore.ssm(golden_pairs.drop_columns(["width_j"]))
    text = golden_pairs.set_column(
        PAIR_COLUMNS.index("x_j"), "x_j", golden_pairs.column("x_j").cast(pa.string())
    )
    with pytest.raises(riskscore.ColumnError, match="x_j: type .* is not supported: a pair column must be Float64"):
        riskscore.ssm(text)
    with pytest.raises(TypeError, match="pyarrow Table"):
        riskscore.ssm([1, 2, 3])


def test_a_text_pair_column_is_refused_in_a_table_without_rows(golden_pairs):
    """Types are checked on the schema, not batch by batch: a zero-row table (no batches, or one
    empty batch) with a text pair column gets the error a table with rows gets, from ssm,
    Model.score and Model.in_domain alike."""
    at = PAIR_COLUMNS.index("x_j")
    text = golden_pairs.set_column(at, "x_j", golden_pairs.column("x_j").cast(pa.string()))
    no_batches = pa.Table.from_batches([], schema=text.schema)
    empty_batch = pa.Table.from_batches([text.to_batches()[0].slice(0, 0)])
    assert no_batches.num_rows == empty_batch.num_rows == 0
    assert empty_batch.column("x_j").num_chunks == 1  # one empty batch (to_batches() drops it)
    model = riskscore.Model.load(MODELS / "drl-default.rsk")
    message = "column x_j: type Utf8 is not supported: a pair column must be Float64, Float32, Int64 or Int32"
    for table in (text, no_batches, empty_batch):
        for call in (riskscore.ssm, model.score, model.in_domain):
            with pytest.raises(riskscore.ColumnError, match=re.escape(message)):
                call(table)
    # A zero-row table of numeric columns is still fine: zero rows out.
    assert riskscore.ssm(golden_pairs.slice(0, 0)).num_rows == 0
    assert model.score(golden_pairs.slice(0, 0)).shape == (0,)


def test_a_column_instead_of_a_frame_is_a_clear_type_error(golden_pairs):
    """A pandas or polars Series (one column, not a frame) is named, not an AttributeError."""
    import polars as pl

    with pytest.raises(TypeError, match="expected a pandas DataFrame, not a pandas Series"):
        riskscore.ssm(golden_pairs.to_pandas()["x_i"])
    with pytest.raises(TypeError, match="expected a polars DataFrame or LazyFrame, not a polars Series"):
        riskscore.ssm(pl.from_arrow(golden_pairs)["x_i"])


def test_truncated_parquet_names_the_file(tmp_path, golden_pairs):
    path = tmp_path / "pairs.parquet"
    pq.write_table(golden_pairs, path)
    data = path.read_bytes()
    path.write_bytes(data[: len(data) // 2])
    with pytest.raises(riskscore.InputFileError, match="pairs.parquet"):
        riskscore.ssm(path)


def test_a_missing_file_is_named_with_the_reason(tmp_path):
    for name in ("gone.parquet", "gone.csv"):
        with pytest.raises(riskscore.InputFileError, match=rf"{name}: cannot read: .*no such file"):
            riskscore.ssm(tmp_path / name)


def test_zero_copy_round_trip(golden_pairs):
    table = golden_pairs.combine_chunks()
    out = riskscore.ssm(table, keep_input=True)
    assert out.column_names == table.column_names + riskscore.computed_columns()
    for name in table.column_names:
        given = table.column(name).chunks[0].buffers()[1].address
        returned = out.column(name).chunks[0].buffers()[1].address
        assert given == returned, f"{name} was copied"


def test_large_tables_are_split_in_order_and_rows_numbered_across_pieces(ngsim_frames):
    pairs = ngsim_frames.select(PAIR_COLUMNS).combine_chunks()
    repeats = -(-600_000 // pairs.num_rows)
    big = pa.concat_tables([pairs] * repeats)
    whole = riskscore.ssm(big)
    assert whole.num_rows == big.num_rows
    one = riskscore.ssm(pairs)
    for k in (0, repeats - 1):
        rows_equal_bitwise(whole.slice(k * pairs.num_rows, pairs.num_rows), one)
    far = big.num_rows - 7
    acc = big.column("acc_j").to_numpy().copy()
    acc[far] = np.nan
    broken = big.set_column(big.column_names.index("acc_j"), "acc_j", pa.array(acc))
    with pytest.raises(riskscore.BadRowError, match=f"row {far} column acc_j"):
        riskscore.ssm(broken, strict=True)


def test_empty_table():
    out = riskscore.ssm(pa.table({c: pa.array([], pa.float64()) for c in PAIR_COLUMNS}))
    assert out.num_rows == 0 and out.column_names == riskscore.computed_columns()


def test_help_teaches():
    text = riskscore.__doc__
    for needle in ("QUICK START", "x_i, y_i", "ttc2d", "BadRowWarning", "strict=True"):
        assert needle in text
    assert "ColumnError" in riskscore.ssm.__doc__


def test_the_gil_is_released_while_the_kernel_runs(ngsim_frames):
    """A Python thread keeps running during a long ssm call (it could not if the GIL were held)."""
    import threading

    big = pa.concat_tables([ngsim_frames.select(PAIR_COLUMNS)] * 20).combine_chunks()
    ticks, done = [0], threading.Event()

    def count():
        while not done.is_set():
            ticks[0] += 1

    counter = threading.Thread(target=count)
    counter.start()
    try:
        before = ticks[0]
        started = time.perf_counter()
        riskscore.ssm(big)
        during, seconds = ticks[0] - before, time.perf_counter() - started
    finally:
        done.set()
        counter.join()
    # A held GIL would let the counter run only at the interpreter's switch interval (5 ms).
    assert during > 1000 * max(seconds, 0.01), (during, seconds)


def test_a_file_without_a_pair_column_is_named(tmp_path, golden_pairs):
    path = tmp_path / "pairs.csv"
    pcsv.write_csv(golden_pairs.drop_columns(["acc_j"]), path)
    model = riskscore.Model.load(MODELS / "drl-default.rsk")
    for call in (riskscore.ssm, model.score, model.in_domain):
        with pytest.raises(riskscore.ColumnError, match=rf"^{re.escape(str(path))}: .*acc_j"):
            call(path)


def test_keep_input_refuses_an_input_that_has_a_computed_column(golden_pairs):
    """ssm(ssm(t, keep_input=True), keep_input=True) would name every computed column twice."""
    once = riskscore.ssm(golden_pairs, keep_input=True)
    with pytest.raises(riskscore.ColumnError, match="already has column.*box_distance, ttc2d"):
        riskscore.ssm(once, keep_input=True)
    renamed = golden_pairs.append_column("TTC2D", golden_pairs.column("x_i"))
    with pytest.raises(riskscore.ColumnError, match="already has column.*TTC2D"):
        riskscore.ssm(renamed, keep_input=True)
    rows_equal_bitwise(riskscore.ssm(once), riskscore.ssm(golden_pairs))


def test_a_numeric_type_the_kernel_does_not_take_is_not_called_non_numeric(golden_pairs):
    """Int16, UInt32, Float16 or Decimal are numbers: the message says which types to cast to."""
    at = PAIR_COLUMNS.index("length_i")
    for kind in (pa.int16(), pa.uint32(), pa.decimal128(12, 3)):
        small = golden_pairs.set_column(at, "length_i", golden_pairs.column("length_i").cast(kind, safe=False))
        with pytest.raises(riskscore.ColumnError) as refused:
            riskscore.ssm(small)
        assert "not numeric" not in str(refused.value)
        assert "length_i: type" in str(refused.value) and "Float64, Float32, Int64 or Int32 (cast it)" in str(refused.value)


def _score_strictly(table):
    return riskscore.ssm(table, strict=True)


def test_bad_row_error_crosses_a_process_pool_with_its_attributes(golden_pairs):
    """A worker's BadRowError reaches the parent: it used to fail to unpickle (its args hold only
    the message), which broke the whole ProcessPoolExecutor (BrokenProcessPool) instead."""
    import concurrent.futures
    import multiprocessing
    import pickle

    copy = pickle.loads(pickle.dumps(riskscore.BadRowError(7, "vx_i", "value inf is not finite", 3)))
    assert (copy.row, copy.column, copy.problem, copy.count) == (7, "vx_i", "value inf is not finite", 3)
    assert str(copy) == "row 7 column vx_i: value inf is not finite (2 more bad rows)"

    vx = golden_pairs.column("vx_i").to_pylist()
    vx[4] = float("inf")
    bad = golden_pairs.set_column(golden_pairs.column_names.index("vx_i"), "vx_i", pa.array(vx))
    with concurrent.futures.ProcessPoolExecutor(
        1, mp_context=multiprocessing.get_context("spawn")
    ) as pool:
        with pytest.raises(riskscore.BadRowError, match="row 4 column vx_i") as raised:
            pool.submit(_score_strictly, bad).result(timeout=120)
    assert (raised.value.row, raised.value.column, raised.value.count) == (4, "vx_i", 1)


def test_a_parquet_file_is_read_as_parquet_whatever_its_name(tmp_path, golden_pairs):
    """`.pq` (and Spark's extension-less part files) used to be parsed as CSV: an InputFileError
    quoting binary garbage ("CSV parse error: Expected 1 columns ...")."""
    expected = riskscore.ssm(golden_pairs)
    for name in ("pairs.pq", "part-00000"):
        pq.write_table(golden_pairs, tmp_path / name)
        rows_equal_bitwise(riskscore.ssm(tmp_path / name), expected)


def test_a_model_blob_given_as_pairs_is_named_as_one():
    """Swapped arguments (model.score("drl-default.rsk")) used to be parsed as CSV: an
    InputFileError quoting the blob's binary bytes."""
    model = riskscore.Model.load(MODELS / "drl-default.rsk")
    with pytest.raises(riskscore.InputFileError,
                       match=r"drl-default\.rsk: a riskscore model blob, not a table of pairs"):
        model.score(MODELS / "drl-default.rsk")
