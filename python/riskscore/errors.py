"""The exceptions riskscore raises and the warning it gives for rows it could not score.

Every message names what to fix: the column, the 0-based row of the input table, or the file.
All exceptions derive from :class:`RiskscoreError` and also from ``ValueError``, so code that
already catches ``ValueError`` for bad data keeps working.
"""
from __future__ import annotations

from typing import Any, Optional, Tuple


class RiskscoreError(Exception):
    """Base class of every riskscore exception."""


class ColumnError(RiskscoreError, ValueError):
    """A pair column is missing, named twice, or not numeric (the message names it)."""


class BadRowError(RiskscoreError, ValueError):
    """A row could not be scored (raised with ``strict=True``; otherwise its outputs are null).

    Attributes: ``row`` (0-based row of the input), ``column`` (the column to blame, or None),
    ``problem`` (what is wrong) and ``count`` (how many rows of the input are bad in all).
    """

    def __init__(self, row: int, column: Optional[str], problem: str, count: int) -> None:
        self.row, self.column, self.problem, self.count = row, column, problem, count
        where = f"row {row}" + (f" column {column}" if column else "")
        more = f" ({count - 1} more bad rows)" if count > 1 else ""
        super().__init__(f"{where}: {problem}{more}")

    def __reduce__(self) -> Tuple[Any, Tuple[int, Optional[str], str, int]]:
        """Pickled from its four attributes (``args`` holds only the message, which
        ``__init__`` does not take): a worker of multiprocessing, concurrent.futures or joblib
        that raises it hands it back to the parent instead of breaking the pool."""
        return (type(self), (self.row, self.column, self.problem, self.count))


class ModelError(RiskscoreError, ValueError):
    """A model blob is not valid (the message names the file and the check that failed), or an
    evaluation names a row or threshold that does not exist."""


class EventsError(RiskscoreError, ValueError):
    """An event folder (or an events/frames table) has problems; the message lists them by file,
    line (or table row) and column."""


class InputFileError(RiskscoreError, ValueError):
    """A file given as input (Parquet or CSV pairs) cannot be read; the message names it."""


class BadRowWarning(UserWarning):
    """Some rows could not be scored; their outputs are null (NaN for scores). The message names
    the first ones by row and column. Pass ``strict=True`` to get :class:`BadRowError` instead."""
