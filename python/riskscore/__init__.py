"""riskscore: collision-risk scoring of ego/partner pairs, computed by riskscore's Rust core
(scorer-core) exactly as on the vehicle's ECU, over Arrow tables.

QUICK START
    import riskscore
    out = riskscore.ssm(pairs)                      # 17 Float32 columns, one row per input row
    model = riskscore.Model.load("models/drl-default.rsk")
    risk = model.score(pairs)                        # float32 numpy array (int8 DRL as on the ECU)
    events, frames = riskscore.read_events("data/ngsim-us101-safe")
    riskscore.ssm(frames)                            # frames carry the pair columns
    report = riskscore.evaluate("data/ngsim-us101-safe", models=["models/drl-default.rsk"])

INPUT (``pairs``): a pyarrow Table or RecordBatch, a pandas or polars DataFrame (a polars
LazyFrame is collected), a dict of numpy arrays, anything with ``__arrow_c_stream__``, or a path to a ``.parquet``/``.csv`` file. It needs
the 18 pair columns of ``riskctl ssm`` (names matched case-insensitively, any order, other
columns ignored); each Float64, Float32, Int64 or Int32:
    x_i, y_i            ego box centre (m, world frame)
    vx_i, vy_i          ego velocity (m/s)
    hx_i, hy_i          ego heading vector (any non-zero length; normalised)
    acc_i               ego longitudinal acceleration (m/s^2)
    length_i, width_i   ego box size (m, >= 0)
    ... and the same nine with suffix _j for the partner.

OUTPUT of ssm (Float32, in this order; ``computed_columns()`` lists them):
    box_distance  exact gap between the two boxes (m), 0 when they touch or overlap
    ttc2d         two-dimensional time-to-collision (s); inf = no conflict; smaller is riskier
    tadv          time advantage (s); inf = no conflict; smaller is riskier
    ei            emergency index (m/s); -inf = no conflict; larger is riskier
    f_l_ego ... f_s   the 13 model features in model-input order
Positions are made relative to the ego in f64 first, so UTM-sized coordinates keep centimetres.

BAD ROWS: a row with a null or non-finite value, a zero heading vector or a negative size cannot
be scored. Its outputs are null (NaN in ``Model.score``), rows stay aligned with the input, and a
``BadRowWarning`` names the first ones by 0-based row and column. With ``strict=True`` the first
bad row raises ``BadRowError`` instead. A missing or non-numeric column raises ``ColumnError``.
All exceptions are in ``riskscore.errors`` and derive from ``RiskscoreError`` and ``ValueError``.

PERFORMANCE: inputs are read through the Arrow C data interface without copying, the work runs
with the GIL released, and large tables are split over all cores (``RAYON_NUM_THREADS`` caps
them). ``riskscore.spark`` runs the same kernels on a Spark cluster (``mapInArrow``).

More: docs/python.md in the riskscore repository.
"""
from __future__ import annotations

import json
import os
import tempfile
from typing import Any, Dict, Iterable, List, Mapping, Optional, Sequence, Tuple, Union

import numpy as np
import pyarrow as pa

from . import _riskscore
from ._inputs import as_table, columns_of, report_bad
from .errors import (
    BadRowError,
    BadRowWarning,
    ColumnError,
    EventsError,
    InputFileError,
    ModelError,
    RiskscoreError,
)

__version__: str = _riskscore.__version__

__all__ = [
    "ssm",
    "computed_columns",
    "Model",
    "read_events",
    "write_events",
    "evaluate",
    "RiskscoreError",
    "ColumnError",
    "BadRowError",
    "BadRowWarning",
    "ModelError",
    "EventsError",
    "InputFileError",
]

PathLike = Union[str, "os.PathLike[str]"]


def computed_columns() -> List[str]:
    """Names of the 17 columns :func:`ssm` computes, in output order."""
    return list(_riskscore.computed_columns())


def ssm(data: Any, *, keep_input: bool = False, strict: bool = False) -> pa.Table:
    """Box distance, TTC2D, TAdv, EI and the 13 features of every ego/partner row of ``data``.

    Returns a ``pyarrow.Table`` of 17 nullable Float32 columns (see ``computed_columns()``), row
    for row with the input; a row that cannot be scored is null in every column. With
    ``keep_input=True`` the input's columns come first (the same buffers, not copies), like the
    output of ``riskctl ssm``; an input that already has a computed column's name (names
    case-insensitive) raises ``ColumnError`` rather than giving a table with that name twice. ``data`` is anything listed under INPUT in ``help(riskscore)``.

    Raises ``ColumnError`` for a missing or non-numeric pair column, ``BadRowError`` for the first
    bad row when ``strict`` (otherwise a ``BadRowWarning``), ``InputFileError`` for an unreadable
    file.
    """
    with columns_of(data):
        table = as_table(data)
        if keep_input:
            taken = {name.lower(): name for name in table.column_names}
            clash = [taken[n] for n in _riskscore.computed_columns() if n in taken]
            if clash:
                raise ColumnError(
                    f"keep_input=True: the input already has column(s) {', '.join(clash)} that "
                    "ssm appends (drop or rename them first)"
                )
        table, listed, count = _riskscore.ssm(table, keep_input)
    report_bad(listed, count, strict)
    return table


class Model:
    """A riskscore model blob (``*.rsk``: DRL int8, DRL f32, MSRA or GSSM), validated on load.

    ``Model.load(path)`` or ``Model.from_bytes(blob)``; ``model.score(pairs)`` scores every row
    through scorer-core exactly as the ECU does (int8 arithmetic for DRL), and ``model.info``
    describes the blob like ``riskctl inspect-model``.
    """

    __slots__ = ("_native",)

    def __init__(self, native: Any) -> None:
        # Made by load/from_bytes; Model("m.rsk") would otherwise build a Model that fails on
        # first use with "'str' object has no attribute '_score'".
        if not isinstance(native, _riskscore.Model):
            raise TypeError(
                f"Model() takes no {type(native).__name__}: use riskscore.Model.load(path) for a "
                "model file or riskscore.Model.from_bytes(blob) for its bytes"
            )
        self._native = native

    @classmethod
    def load(cls, path: PathLike) -> "Model":
        """Read and validate a model file. Raises ``OSError`` if it cannot be read (its errno's
        subclass: ``FileNotFoundError`` for a missing file) and
        ``ModelError`` (naming the file and the failed check) if it is not a valid blob."""
        return cls(_riskscore.Model.load(os.fspath(path)))

    @classmethod
    def from_bytes(cls, blob: bytes) -> "Model":
        """Validate a model blob held in memory (e.g. broadcast to Spark executors)."""
        return cls(_riskscore.Model.from_bytes(bytes(blob)))

    def to_bytes(self) -> bytes:
        """The blob's bytes, as ``from_bytes`` takes them."""
        return self._native.to_bytes()

    @property
    def path(self) -> Optional[str]:
        """The file the model was loaded from (None for ``from_bytes``)."""
        return self._native.path

    @property
    def info(self) -> Dict[str, Any]:
        """What ``riskctl inspect-model`` reports: ``kind`` (e.g. "drl-int8"), ``int8``,
        ``format_version``, ``input_schema``, ``encoding``, ``inputs`` (names of the network's
        inputs), ``payload_bytes``, ``payload_crc32``, ``total_bytes``, ``default_threshold``,
        ``threshold_rule`` (how the default threshold was chosen), ``domain_policy`` (what scoring
        does outside the training domain; ``None`` without a record) and ``blend_network_weight``
        (the network's share of the score inside the domain under ``"blend"``, else ``None``)."""
        return dict(self._native.info)

    def score(self, data: Any, *, strict: bool = False) -> np.ndarray:
        """The model's risk score of every row of ``data`` as a float32 numpy array, row for
        row (read-only: it views the scores' Arrow buffer without a copy; ``.copy()`` it to
        change values); NaN where a row cannot be scored (``BadRowWarning``, or ``BadRowError`` when
        ``strict``). Input as for :func:`ssm`. Higher is riskier. A blob with a training-domain
        record is scored through its guard, as ``riskctl score`` and the ECU score it: outside
        the domain the blob's policy decides (the shipped DRL falls back to a kinematic score)."""
        with columns_of(data):
            scores, listed, count = self._native._score(as_table(data))
        report_bad(listed, count, strict)
        return scores.to_numpy(zero_copy_only=True)

    def in_domain(self, data: Any, *, strict: bool = False) -> np.ndarray:
        """Whether each row of ``data`` lies inside the model's training domain, as a bool numpy
        array row for row: the flag ``riskctl score`` writes as ``<model>_in_domain``, computed
        by the same core. Always True for a blob without a training-domain record; False where
        a row cannot be scored (``BadRowWarning``, or ``BadRowError`` when ``strict``). Outside
        the domain :meth:`score` follows the blob's policy (``model.info["domain_policy"]``:
        ``"blend"``, ``"fallback"``, ``"clamp"``, ``"flag-only"``, or ``None`` without a record);
        under ``"blend"`` (the shipped DRL's) the score inside mixes in the kinematic fallback."""
        with columns_of(data):
            flags, listed, count = self._native._in_domain(as_table(data))
        report_bad(listed, count, strict)
        return flags.to_numpy(zero_copy_only=False)

    def __reduce__(self) -> Tuple[Any, Tuple[bytes]]:
        """Pickled as its blob (for multiprocessing, joblib or a Spark UDF's closure); the copy
        is made with :meth:`from_bytes`, so its ``path`` is None."""
        return (Model.from_bytes, (self.to_bytes(),))

    def __repr__(self) -> str:
        return repr(self._native)


# The problems a ``BadRowWarning`` lists each leave their event out, but for this one kind
# (riskctl's listing says it per problem).
_UNKNOWN_ID_ROWS = "except frames of an event id that events.csv lacks: only those rows are dropped"


def read_events(directory: PathLike, *, skip_bad: bool = False) -> Tuple[pa.Table, pa.Table]:
    """Read an event folder (``events.csv`` + ``frames.csv``, docs/event-format.md) as two tables.

    ``events``: event_id, kind (crash, near_crash, safe), t_start, t_end, t_impact (null for
    safe events), length_ego, width_ego, length_sur, width_sur. ``frames``: event_id, time and the
    18 pair columns x_i ... width_j (ego = _i, partner = _j; box sizes from the event; acc_j as
    recorded, or derived from the partner's velocity as riskctl does), so
    ``riskscore.ssm(frames)`` and ``model.score(frames)`` work on it directly.

    Every row is validated as ``riskctl`` does. A folder with problems raises ``EventsError``
    listing them (file:line: column: event: problem); with ``skip_bad=True`` the events with
    problems are left out (frames of an event id that events.csv lacks drop only those rows) and a
    ``BadRowWarning`` lists them instead. Notes, which leave no event
    out (a file without a final newline, a hole in the frames, ...), warn with a ``UserWarning``
    of their own and are not counted as problems.
    """
    events, frames, problems, notes, count = _riskscore.read_events(os.fspath(directory))
    if notes:
        _warn_notes(notes, directory)
    if count:
        listing = "\n  ".join(problems)
        message = f"{count} problem(s) in event folder {os.fspath(directory)}:\n  {listing}"
        if not skip_bad:
            raise EventsError(message + "\n(skip_bad=True reads the valid events)")
        import warnings

        warnings.warn(
            f"{message}\n(each leaves its event out, {_UNKNOWN_ID_ROWS})", BadRowWarning, stacklevel=2
        )
    return events, frames


def _warn_notes(notes, directory: PathLike) -> None:
    """Notes leave nothing out (a file without a final newline, speeds that outrun the positions,
    a hole in the frames, a repeated header line: docs/event-format.md lists them), so they warn
    instead of raising."""
    import warnings

    listing = "\n  ".join(notes)
    warnings.warn(f"event folder {os.fspath(directory)}:\n  {listing}", UserWarning, stacklevel=3)


_EVENT_TYPES = [
    ("event_id", pa.string()),
    ("kind", pa.string()),
    ("t_start", pa.float64()),
    ("t_end", pa.float64()),
    ("t_impact", pa.float64()),
    ("length_ego", pa.float32()),
    ("width_ego", pa.float32()),
    ("length_sur", pa.float32()),
    ("width_sur", pa.float32()),
]
_STATE = ["x", "y", "vx", "vy", "hx", "hy", "acc"]
_FRAME_TYPES = (
    [("event_id", pa.string()), ("time", pa.float64())]
    + [(f"{f}_i", pa.float32()) for f in _STATE]
    + [(f"{f}_j", pa.float32()) for f in _STATE]
)


def _is_number(kind: pa.DataType) -> bool:
    """Whether a column of type ``kind`` is read as numbers: integers, floats, decimals (or
    dictionary-encoded ones), and the all-null type (``pa.array([])``: nothing to misread)."""
    if pa.types.is_dictionary(kind):
        kind = kind.value_type
    return (
        pa.types.is_integer(kind)
        or pa.types.is_floating(kind)
        or pa.types.is_decimal(kind)
        or pa.types.is_null(kind)
    )


def _select(table: pa.Table, what: str, wanted: Sequence[Tuple[str, pa.DataType]]) -> pa.Table:
    """The ``wanted`` columns of ``table`` (names case-insensitive), cast to their types.

    Where a number is wanted, a column that is not numeric (text, bool, dates, ...) is refused
    from the table's schema, not by whether its values happen to cast: a zero-row table has no
    value to fail on, and must be refused like one with rows."""
    by_name: Dict[str, int] = {}
    for k, name in enumerate(table.column_names):
        if name.lower() in by_name:
            raise ColumnError(f"{what}: column {name!r} appears twice (names are case-insensitive)")
        by_name[name.lower()] = k
    columns = []
    for name, kind in wanted:
        if name not in by_name:
            raise ColumnError(f"{what}: missing column {name!r}")
        column = table.column(by_name[name])
        if (pa.types.is_floating(kind) or pa.types.is_integer(kind)) and not _is_number(column.type):
            raise ColumnError(
                f"{what}: column {name!r} ({column.type}) is not {kind}: it must be numeric "
                "(integer or float; cast it)"
            )
        try:
            columns.append(column.cast(kind))
        except (pa.ArrowInvalid, pa.ArrowNotImplementedError) as e:
            raise ColumnError(f"{what}: column {name!r} ({column.type}) is not {kind}: {e}") from e
    return pa.Table.from_arrays(columns, names=[n for n, _ in wanted])


def write_events(
    directory: PathLike, events: Any, frames: Any, *, overwrite: bool = False
) -> None:
    """Write an event folder from an events table and a frames table (as :func:`read_events`
    returns them; names case-insensitive, numeric types cast; a column that is not numeric where
    a number belongs, text included, raises ``ColumnError`` naming it, whether or not the table
    has rows). The box sizes come from the events
    table (a folder stores them per event; frames' own length_i ... width_j are not read, so
    change sizes in the events table); frames need event_id, time, x_i ... acc_i and x_j ...
    acc_j, in time order per event.

    Both files are written under temporary names and renamed into place, so a failure leaves the
    folder as it was. Existing ``events.csv``/``frames.csv`` raise ``FileExistsError`` unless
    ``overwrite=True``. A missing or non-finite value raises ``EventsError`` naming the table, row
    and column; an unknown kind or an event_id missing from the events table too. The tables are
    also checked as :func:`read_events` checks a folder (frames in time order within the event's
    interval, event_ids unique, every event with frames, t_impact on crash/near_crash events
    only, plausible sizes and speeds): a problem raises ``EventsError`` listing them by table row
    and nothing is written.
    """
    ev = _select(as_table(events), "events", _EVENT_TYPES)
    fr = _select(as_table(frames), "frames", _FRAME_TYPES)
    _riskscore.write_events(os.fspath(directory), ev, fr, overwrite)


ModelSpec = Union[PathLike, Model]
# A number (numpy's float32 and integer scalars too, as a threshold picked from a float32 score
# array is), "default", "none" or None.
Threshold = Union[float, "np.floating[Any]", "np.integer[Any]", str, None]


def _model_specs(
    models: Union[ModelSpec, Sequence[ModelSpec], Mapping[str, ModelSpec]], scratch: str
) -> List[str]:
    """``[NAME=]FILE`` specs. A loaded ``Model`` is evaluated from the blob it holds (written to a
    folder of its own in ``scratch`` under its file's name, so rows are named as for the file),
    not re-read from a path that may since have changed, be relative to another folder, or be
    none (``from_bytes``, unpickled)."""

    def path_of(m: ModelSpec) -> str:
        if not isinstance(m, (str, os.PathLike, Model)):
            raise TypeError(
                f"models: {m!r} ({type(m).__name__}) is not a model: give a model file's path "
                "(str or os.PathLike) or a riskscore.Model"
            )
        if isinstance(m, Model):
            folder = tempfile.mkdtemp(dir=scratch)
            blob = os.path.join(folder, os.path.basename(m.path) if m.path else "model.rsk")
            with open(blob, "wb") as out:
                out.write(m.to_bytes())
            return blob
        path = os.fspath(m)
        # The spec parser reads `NAME=FILE` when the text before the first "=" has no path
        # separator: a relative path like "lr=0.01/drl.rsk" would become a row "lr" reading
        # "0.01/drl.rsk". A path is never a name here (names come from a dict), so such a path
        # is given with a leading "./", which the parser takes whole.
        if isinstance(path, str) and "=" in path:
            before = path.split("=", 1)[0]
            if "/" not in before and "\\" not in before:
                path = os.path.join(os.curdir, path)
        return path

    if isinstance(models, Mapping):
        for name in models:
            # The row name travels as NAME in NAME=FILE: the parser would split a name with "="
            # elsewhere, and take one with a path separator (or an empty one) as part of the file.
            text = str(name)
            if not text or any(c in text for c in "=/\\"):
                raise ModelError(
                    f"models: row name {name!r} cannot be empty or contain '=', '/' or '\\'"
                )
        return [f"{name}={path_of(m)}" for name, m in models.items()]
    if isinstance(models, (str, os.PathLike, Model)):
        return [path_of(models)]
    if not isinstance(models, Iterable) or isinstance(models, (bytes, bytearray)):
        raise TypeError(
            f"models: expected a model file's path, a riskscore.Model, a list of them or a "
            f"{{row name: path or Model}} dict, not {type(models).__name__} "
            "(models=() evaluates the TTC2D, TAdv and EI baselines alone)"
        )
    return [path_of(m) for m in models]


def _choice(value: Threshold, row: Optional[str] = None) -> Union[float, str]:
    if value is None:
        return "none"
    where = f"thresholds[{row!r}]" if row is not None else "thresholds"
    if isinstance(value, str):
        if value not in ("default", "none"):
            raise ModelError(f'{where}: {value!r} is not a number, "default", "none" or None')
        return value
    if isinstance(value, (bool, np.bool_)):
        # float(True) would put every model at threshold 1.0 without a word.
        raise ModelError(f'{where}: {value!r} is not a number, "default", "none" or None')
    return float(value)


def evaluate(
    events: PathLike,
    models: Union[ModelSpec, Sequence[ModelSpec], Mapping[str, ModelSpec]] = (),
    *,
    thresholds: Union[Threshold, Mapping[str, Threshold]] = "default",
    skip_bad_events: bool = False,
) -> Dict[str, Any]:
    """Evaluate an event folder exactly as ``riskctl evaluate --json`` does, returning its object:
    ``{"events": {...}, "methods": [{"name", "A_ROC_90", ...}], "operating_points": [...]}``.

    ``models``: model files (paths or loaded ``Model``s; a ``{name: path}`` dict names the rows
    like ``--model NAME=FILE``). A ``Model`` is evaluated from the blob it holds (also one made
    with ``from_bytes`` or unpickled), not re-read from its file. The TTC2D, TAdv and EI baselines follow,
    then TAdv-corridor when a model reads it (the shipped MSRA does). ``thresholds`` sets the
    operating points like ``--threshold``: ``"default"`` (each model at its own default
    threshold), a number (every model at it), ``"none"``/None (no operating points), or a dict
    ``{row name: number | "default" | "none"/None}`` (baselines too; other rows keep defaults).
    A folder with bad rows raises ``EventsError`` listing them unless ``skip_bad_events=True``
    (then a ``BadRowWarning`` lists them); notes, which leave no event out, warn with a
    ``UserWarning`` of their own, and so do valid events that yield no sequence under the
    preparation rules (left out of the metrics, as ``riskctl evaluate`` lists them on stderr).
    """
    if isinstance(thresholds, Mapping):
        every, by_name = None, {name: _choice(t, name) for name, t in thresholds.items()}
    else:
        every, by_name = _choice(thresholds), {}
    with tempfile.TemporaryDirectory(prefix="riskscore-models-") as scratch:
        specs = _model_specs(models, scratch)
        text, problems, notes, count, unprepared = _riskscore.evaluate(
            os.fspath(events), specs, every, by_name, skip_bad_events
        )
    if notes:
        _warn_notes(notes, events)
    if unprepared:
        # Valid events the preparation rules turn into no sequence (a safe event shorter than 2 s
        # or never calm, a conflict without a frame up to its endpoint): left out of the metrics,
        # as riskctl evaluate lists them on stderr.
        import warnings

        listing = "\n  ".join(unprepared)
        warnings.warn(
            f"event folder {os.fspath(events)}: {len(unprepared)} event(s) yield no sequence under "
            f"the preparation rules (left out of the metrics; docs/event-format.md):\n  {listing}",
            UserWarning,
            stacklevel=2,
        )
    if count:
        import warnings

        listing = "\n  ".join(problems)
        warnings.warn(
            f"{count} problem(s) in event folder {os.fspath(events)} "
            f"(each leaves its event out of the metrics, {_UNKNOWN_ID_ROWS}):\n  {listing}",
            BadRowWarning,
            stacklevel=2,
        )
    return json.loads(text)
