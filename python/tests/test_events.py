"""riskscore.read_events / write_events: the folder format round trip and its errors."""
import re
import shutil

import pyarrow as pa
import pyarrow.compute as pc
import pytest

import riskscore
from conftest import NGSIM_SAFE, PAIR_COLUMNS, ngsim_with_a_bad_frame


def test_real_folder_reads_with_every_frame():
    events, frames = riskscore.read_events(NGSIM_SAFE)
    assert events.num_rows == 376
    frame_lines = sum(1 for _ in open(NGSIM_SAFE / "frames.csv")) - 1
    assert frames.num_rows == frame_lines
    assert frames.column_names[:2] == ["event_id", "time"]
    assert frames.column_names[2:] == PAIR_COLUMNS
    assert set(events.column("kind").to_pylist()) == {"safe"}


def test_written_folder_reads_back_identically(tmp_path):
    events, frames = riskscore.read_events(NGSIM_SAFE)
    riskscore.write_events(tmp_path / "copy", events, frames)
    again_events, again_frames = riskscore.read_events(tmp_path / "copy")
    assert again_events.equals(events)
    assert again_frames.equals(frames)


def test_existing_files_are_not_overwritten_by_accident(tmp_path):
    events, frames = riskscore.read_events(NGSIM_SAFE)
    target = tmp_path / "folder"
    first = events.slice(0, 2)
    mask = pc.is_in(frames.column("event_id"), value_set=first.column("event_id"))
    riskscore.write_events(target, first, frames.filter(mask))
    before = (target / "events.csv").read_bytes()
    with pytest.raises(FileExistsError, match="overwrite=True"):
        riskscore.write_events(target, events, frames)
    assert (target / "events.csv").read_bytes() == before
    riskscore.write_events(target, events, frames, overwrite=True)
    assert riskscore.read_events(target)[0].num_rows == 376


def test_bad_frames_are_refused_naming_row_and_column(tmp_path):
    events, frames = riskscore.read_events(NGSIM_SAFE)
    x = frames.column("x_j").to_pylist()
    x[11] = float("nan")
    broken = frames.set_column(frames.column_names.index("x_j"), "x_j", pa.array(x, pa.float32()))
    with pytest.raises(riskscore.EventsError, match="frames row 11 column x_j: value NaN is not finite"):
        riskscore.write_events(tmp_path / "out", events, broken)
    assert not (tmp_path / "out" / "frames.csv").exists()
    with pytest.raises(riskscore.ColumnError, match="missing column 'acc_i'"):
        riskscore.write_events(tmp_path / "out", events, frames.drop_columns(["acc_i"]))
    kinds = events.column("kind").to_pylist()
    kinds[0] = "fender_bender"
    odd = events.set_column(1, "kind", pa.array(kinds))
    with pytest.raises(riskscore.EventsError, match="events row 0 column kind: unknown kind"):
        riskscore.write_events(tmp_path / "out", odd, frames)


def test_a_text_column_where_a_number_belongs_is_refused_with_or_without_rows(tmp_path):
    """The column types are checked on the tables' schemas: a zero-row events or frames table
    with a text column where a number belongs is refused like one with rows (it used to cast,
    with no value to fail on, and write an empty folder); text that would parse is refused too."""
    events, frames = riskscore.read_events(NGSIM_SAFE)
    first = events.slice(0, 1)
    mask = pc.is_in(frames.column("event_id"), value_set=first.column("event_id"))
    its_frames = frames.filter(mask)

    def as_text(table, name):
        at = table.column_names.index(name)
        return table.set_column(at, name, table.column(name).cast(pa.string()))

    cases = [
        ("events", "t_start", "double", as_text(first, "t_start"), its_frames),
        ("frames", "x_j", "float", first, as_text(its_frames, "x_j")),
    ]
    for what, name, kind, ev, fr in cases:
        message = re.escape(f"{what}: column '{name}' (string) is not {kind}: it must be numeric")
        # With rows: the text is the numbers' own digits, which would parse; refused by type.
        with pytest.raises(riskscore.ColumnError, match=message):
            riskscore.write_events(tmp_path / f"{what}-rows", ev, fr)
        # Without rows there is no value for a cast to fail on: the same error all the same.
        with pytest.raises(riskscore.ColumnError, match=message):
            riskscore.write_events(tmp_path / f"{what}-empty", ev.slice(0, 0), fr.slice(0, 0))
        assert not (tmp_path / f"{what}-rows").exists()
        assert not (tmp_path / f"{what}-empty").exists()

    # The extension itself checks the schema before reading a row: a wrong type is a
    # ColumnError naming the column, not a panic in a row accessor, with or without rows.
    from riskscore import _riskscore

    text_events = as_text(first, "t_start")
    for rows in (1, 0):
        with pytest.raises(riskscore.ColumnError, match=r'events: column "t_start" \(Utf8\) is not Float64'):
            _riskscore.write_events(
                str(tmp_path / "raw"), text_events.slice(0, rows), its_frames.slice(0, 0), False
            )
    assert not (tmp_path / "raw").exists()


def test_a_folder_with_bad_rows_is_refused_unless_skipped(tmp_path):
    folder = ngsim_with_a_bad_frame(tmp_path / "bad")
    with pytest.raises(riskscore.EventsError, match=r"frames.csv:6:"):
        riskscore.read_events(folder)
    with pytest.warns(riskscore.BadRowWarning, match="frames.csv:6:"):
        events, _frames = riskscore.read_events(folder, skip_bad=True)
    assert events.num_rows == 375
    with pytest.raises(riskscore.EventsError, match="events.csv"):
        riskscore.read_events(tmp_path / "nowhere")


def test_a_last_line_without_newline_is_read_and_noted(tmp_path):
    folder = tmp_path / "cut"
    shutil.copytree(NGSIM_SAFE, folder)
    text = (folder / "frames.csv").read_text()
    assert text.endswith("\n")
    (folder / "frames.csv").write_text(text[:-1])
    lines = text.count("\n")
    with pytest.warns(UserWarning, match=rf"frames.csv:{lines}: no newline at the end of the file"):
        events, frames = riskscore.read_events(folder)
    assert events.num_rows == 376
    assert frames.num_rows == lines - 1


def test_tables_the_loader_would_refuse_are_not_written(tmp_path):
    """Frames out of time order, a repeated event_id, an event without frames: write_events
    refuses them, naming the table row, instead of writing a folder read_events refuses (over
    a good one with overwrite=True)."""
    events, frames = riskscore.read_events(NGSIM_SAFE)
    target = tmp_path / "folder"
    riskscore.write_events(target, events, frames)
    before = {name: (target / name).read_bytes() for name in ("events.csv", "frames.csv")}
    first = events.column("event_id")[0].as_py()
    rows = pc.indices_nonzero(pc.equal(frames.column("event_id"), first)).to_pylist()
    order = list(range(frames.num_rows))
    order[rows[1]], order[rows[2]] = order[rows[2]], order[rows[1]]
    swapped = frames.take(order)
    with pytest.raises(riskscore.EventsError, match=rf"frames row {rows[2]} column time: event .*is before the previous frame's .* \(row {rows[1]}\)"):
        riskscore.write_events(target, events, swapped, overwrite=True)
    with pytest.raises(riskscore.EventsError, match=r"events row 376 column event_id: .*already used on row 0;"):
        riskscore.write_events(target, pa.concat_tables([events, events.slice(0, 1)]), frames, overwrite=True)
    with pytest.raises(riskscore.EventsError, match=r"events row 0: event .*: event has no frames"):
        riskscore.write_events(target, events, frames.filter(pc.not_equal(frames.column("event_id"), first)), overwrite=True)
    assert {name: (target / name).read_bytes() for name in before} == before
    with pytest.raises(riskscore.EventsError, match="has no frames"):
        riskscore.write_events(tmp_path / "new", events, frames.slice(0, 0))
    assert not (tmp_path / "new").exists()


def test_sizes_edited_in_the_events_table_are_written_with_frames_as_read(tmp_path):
    """The documented way to change a box size: edit the events table, pass the frames as
    read_events gave them (their stale length columns are not read)."""
    events, frames = riskscore.read_events(NGSIM_SAFE)
    lengths = events.column("length_sur").to_numpy().copy()
    lengths[0] = 5.5
    edited = events.set_column(events.column_names.index("length_sur"), "length_sur", pa.array(lengths))
    riskscore.write_events(tmp_path / "out", edited, frames)
    again_events, again_frames = riskscore.read_events(tmp_path / "out")
    assert again_events.column("length_sur")[0].as_py() == 5.5
    first = pc.equal(again_frames.column("event_id"), events.column("event_id")[0])
    assert set(again_frames.filter(first).column("length_j").to_pylist()) == {5.5}


def test_a_refused_frame_is_named_by_the_frames_table_column(tmp_path):
    """The loader's check names frames.csv's hx_ego; the message names the table's hx_i."""
    events, frames = riskscore.read_events(NGSIM_SAFE)
    hx = frames.column("hx_i").to_numpy().copy()
    hx[30] = 2.0
    odd = frames.set_column(frames.column_names.index("hx_i"), "hx_i", pa.array(hx))
    with pytest.raises(riskscore.EventsError, match=r"frames row 30 column hx_i: event .*: heading norm"):
        riskscore.write_events(tmp_path / "out", events, odd)
    widths = events.column("width_sur").to_numpy().copy()
    widths[2] = 9.0
    wide = events.set_column(events.column_names.index("width_sur"), "width_sur", pa.array(widths))
    with pytest.raises(riskscore.EventsError, match=r"events row 2 column width_sur: event .*: dimension 9 m is outside"):
        riskscore.write_events(tmp_path / "out", wide, frames)


def test_write_events_needs_no_system_temp_folder(tmp_path, monkeypatch):
    """The check that the tables read back is made in a scratch folder beside the destination,
    not in $TMPDIR (missing, small or read-only in containers and on Spark executors); the
    scratch folder is gone afterwards, whether the tables were written or refused."""
    events, frames = riskscore.read_events(NGSIM_SAFE)
    monkeypatch.setenv("TMPDIR", str(tmp_path / "nonexistent"))
    target = tmp_path / "out" / "folder"
    riskscore.write_events(target, events, frames)
    riskscore.write_events(target, events, frames, overwrite=True)
    kinds = events.column("kind").to_pylist()
    kinds[0] = "crash"  # without t_impact: the loader refuses it
    with pytest.raises(riskscore.EventsError, match="events row 0"):
        riskscore.write_events(target, events.set_column(1, "kind", pa.array(kinds)), frames, overwrite=True)
    monkeypatch.delenv("TMPDIR")
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == ["folder"]
    assert sorted(p.name for p in target.iterdir()) == ["events.csv", "frames.csv"]
    assert riskscore.read_events(target)[0].num_rows == 376


def test_notes_are_neither_listed_nor_counted_as_problems(tmp_path):
    """A note (here a hole in the frames) leaves nothing out: it warns on its own, not among the
    problems whose events are left out."""
    import warnings

    from conftest import folder_with_a_problem_and_a_note

    folder = folder_with_a_problem_and_a_note(tmp_path / "folder")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        events, _frames = riskscore.read_events(folder, skip_bad=True)
    assert events.num_rows == 1
    bad = [str(w.message) for w in caught if w.category is riskscore.BadRowWarning]
    notes = [str(w.message) for w in caught if w.category is UserWarning]
    assert len(bad) == 1 and len(notes) == 1, caught
    assert bad[0].startswith("1 problem(s)") and bad[0].count("\n  ") == 1
    assert "Safe" in bad[0] and "frames jump" not in bad[0]
    assert "frames jump" in notes[0] and "Safe" not in notes[0]
    with warnings.catch_warnings(record=True):
        warnings.simplefilter("always")
        with pytest.raises(riskscore.EventsError) as refused:
            riskscore.read_events(folder)
    assert str(refused.value).startswith("1 problem(s)") and "frames jump" not in str(refused.value)
