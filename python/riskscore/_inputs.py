"""Everything riskscore accepts as a table of pairs, turned into a ``pyarrow.Table``.

Conversions only, and zero-copy wherever pyarrow allows it (numpy-backed float columns without
nulls, Arrow-backed frames, anything exporting ``__arrow_c_stream__``).
"""
from __future__ import annotations

import os
import warnings
from contextlib import contextmanager
from typing import Any, Iterator, List, Optional, Tuple

import pyarrow as pa

from .errors import BadRowError, BadRowWarning, ColumnError, InputFileError


def as_table(data: Any) -> pa.Table:
    """``data`` as a pyarrow Table; see :func:`riskscore.ssm` for what is accepted."""
    if isinstance(data, pa.Table):
        return data
    if isinstance(data, pa.RecordBatch):
        return pa.Table.from_batches([data])
    if isinstance(data, (str, os.PathLike)):
        return read_file(os.fspath(data))
    module = type(data).__module__.split(".")[0]
    if module == "pandas":
        import pandas as pd

        if isinstance(data, pd.DataFrame):
            return pa.Table.from_pandas(data, preserve_index=False)
        raise TypeError(f"expected a pandas DataFrame, not a pandas {type(data).__name__}")
    if module == "polars":
        import polars as pl

        if isinstance(data, pl.LazyFrame):
            data = data.collect()
        if isinstance(data, pl.DataFrame):
            return data.to_arrow()
        raise TypeError(f"expected a polars DataFrame or LazyFrame, not a polars {type(data).__name__}")
    if isinstance(data, dict):
        return pa.table(data)
    if hasattr(data, "__arrow_c_stream__"):
        return pa.table(data)
    raise TypeError(
        f"expected a pyarrow Table or RecordBatch, a pandas or polars DataFrame, a dict of arrays "
        f"or a path to a .parquet/.csv file, not {type(data).__name__}"
    )


@contextmanager
def columns_of(data: Any) -> Iterator[None]:
    """A ``ColumnError`` about ``data`` names the file when ``data`` is a path."""
    try:
        yield
    except ColumnError as e:
        if isinstance(data, (str, os.PathLike)):
            raise ColumnError(f"{os.fspath(data)}: {e}") from None
        raise


def _starts_with(path: str, magic: bytes) -> bool:
    """Whether the file at ``path`` begins with ``magic`` (False when it cannot be read: the
    reader then names the problem)."""
    try:
        with open(path, "rb") as f:
            return f.read(len(magic)) == magic
    except OSError:
        return False


def read_file(path: str) -> pa.Table:
    """A Parquet (``.parquet``, or any name whose file starts with Parquet's magic ``PAR1``, such
    as ``.pq``) or CSV file of pairs, with the file named in any error."""
    if _starts_with(path, b"RSKM"):
        # Parsed as CSV, a blob gives a parse error quoting its binary bytes.
        raise InputFileError(
            f"{path}: a riskscore model blob, not a table of pairs (riskscore.Model.load reads it)"
        )
    try:
        if path.lower().endswith(".parquet") or _starts_with(path, b"PAR1"):
            import pyarrow.parquet as pq

            return pq.read_table(path)
        import pyarrow.csv as pcsv

        return pcsv.read_csv(path)
    except FileNotFoundError as e:
        # pyarrow's message for a missing Parquet file is the bare path.
        raise InputFileError(f"{path}: cannot read: no such file") from e
    except (OSError, pa.ArrowException) as e:
        raise InputFileError(f"{path}: cannot read: {e}") from e


def report_bad(listed: List[Tuple[int, Optional[str], str]], count: int, strict: bool) -> None:
    """Raise (``strict``) or warn about the bad rows one call found."""
    if count == 0:
        return
    row, column, problem = listed[0]
    if strict:
        raise BadRowError(row, column, problem, count)
    shown = "; ".join(
        f"row {r}" + (f" column {c}" if c else "") + f": {p}" for r, c, p in listed[:5]
    )
    more = f"; ... and {count - 5} more" if count > 5 else ""
    warnings.warn(
        f"{count} row(s) could not be scored and are null in the output: {shown}{more}",
        BadRowWarning,
        stacklevel=3,
    )
