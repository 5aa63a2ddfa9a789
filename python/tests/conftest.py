"""Shared fixtures: the repository, the `riskctl` binary the parity tests compare against, and
small real tables of pairs.

`riskctl` is taken from $RISKCTL, else $CARGO_TARGET_DIR/debug/riskctl (target/debug/riskctl when
unset; scripts/test.sh builds it before this suite runs). Parity tests need it; a missing binary
fails them rather than skipping them.
"""
import os
import pathlib
import subprocess

import pyarrow as pa
import pytest

import riskscore

REPO = pathlib.Path(__file__).resolve().parents[2]
GOLDEN = REPO / "tests" / "data" / "golden_surrogates.csv"
NGSIM_SAFE = REPO / "data" / "ngsim-us101-safe"
MODELS = REPO / "models"
STATE = ["x", "y", "vx", "vy", "hx", "hy", "acc", "length", "width"]
PAIR_COLUMNS = [f"{f}_i" for f in STATE] + [f"{f}_j" for f in STATE]


@pytest.fixture(scope="session")
def riskctl():
    # Where cargo put it: $CARGO_TARGET_DIR (relative to the repository) when set.
    target = REPO / os.environ.get("CARGO_TARGET_DIR", "target")
    path = pathlib.Path(os.environ.get("RISKCTL", target / "debug" / "riskctl"))
    if not path.is_file():
        pytest.fail(f"riskctl not found at {path}: build it (cargo build -p host-tools) or set RISKCTL")

    def run(*args, **kwargs):
        return subprocess.run(
            [str(path), *map(str, args)], check=True, capture_output=True, text=True, **kwargs
        )

    return run


@pytest.fixture(scope="session")
def golden_pairs():
    """The golden cases' 18 pair columns (Float64, as a CSV reader parses them)."""
    import pyarrow.csv as pcsv

    return pcsv.read_csv(GOLDEN).select(PAIR_COLUMNS)


@pytest.fixture(scope="session")
def ngsim_frames():
    """Every frame of the shipped real NGSIM US-101 safe interactions, with the pair columns."""
    _events, frames = riskscore.read_events(NGSIM_SAFE)
    return frames


def rows_equal_bitwise(a: pa.Table, b: pa.Table) -> None:
    """Same column names and the same f32 bits (or nulls) in every row."""
    import numpy as np

    assert a.column_names == b.column_names
    assert a.num_rows == b.num_rows
    for name in a.column_names:
        x = a.column(name).combine_chunks()
        y = b.column(name).combine_chunks()
        assert x.null_count == y.null_count, name
        xv = x.fill_null(0).to_numpy().astype(np.float32).view(np.uint32)
        yv = y.fill_null(0).to_numpy().astype(np.float32).view(np.uint32)
        diff = np.nonzero(xv != yv)[0]
        assert diff.size == 0, f"{name}: first difference at row {diff[:1]}"


def ngsim_with_a_bad_frame(folder: pathlib.Path) -> pathlib.Path:
    """The real US-101 extract copied to `folder`, with `oops` for a number on frames.csv line 6
    (a problem: its event is left out)."""
    import shutil

    shutil.copytree(NGSIM_SAFE, folder)
    lines = (folder / "frames.csv").read_text().splitlines(keepends=True)
    fields = lines[5].split(",")
    fields[2] = "oops"
    lines[5] = ",".join(fields)
    (folder / "frames.csv").write_text("".join(lines))
    return folder


def folder_with_a_problem_and_a_note(folder: pathlib.Path) -> pathlib.Path:
    """Two real events written to `folder`: the first with a hole in its frames (a FrameGap
    note: the event is kept), the second with kind `Safe` (a problem: the event is left out)."""
    import pyarrow.compute as pc

    events, frames = riskscore.read_events(NGSIM_SAFE)
    two = events.slice(0, 2)
    first, second = two.column("event_id").to_pylist()
    rows = pc.indices_nonzero(pc.equal(frames.column("event_id"), first)).to_pylist()
    others = pc.indices_nonzero(pc.equal(frames.column("event_id"), second)).to_pylist()
    riskscore.write_events(folder, two, frames.take(rows[:5] + rows[15:] + others))
    text = (folder / "events.csv").read_text().splitlines(keepends=True)
    assert text[2].startswith(f"{second},safe,")
    text[2] = text[2].replace(",safe,", ",Safe,", 1)
    (folder / "events.csv").write_text("".join(text))
    return folder
