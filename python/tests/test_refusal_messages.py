"""riskscore.evaluate on a folder whose only problems are frames of an event id that events.csv
lacks: no event is left out, only those rows are dropped. The refusal and the skip_bad_events
warning used to say "those events are left out of the metrics"."""
import shutil

import pytest

import riskscore
from conftest import MODELS, NGSIM_SAFE

DRL = MODELS / "drl-default.rsk"


def folder_with_frames_of_an_unknown_id(folder):
    """The real US-101 extract copied to `folder`, plus two frames of event `ghost`."""
    shutil.copytree(NGSIM_SAFE, folder)
    frames = folder / "frames.csv"
    text = frames.read_text()
    first = text.splitlines()[1]
    ghost = "ghost" + first[first.index(","):]
    frames.write_text(f"{text}{ghost}\n{ghost}\n")
    return folder


def test_frames_of_an_unknown_id_are_refused_saying_no_event_is_left_out(tmp_path):
    folder = folder_with_frames_of_an_unknown_id(tmp_path / "folder")
    events = len((folder / "events.csv").read_text().splitlines()) - 1
    with pytest.raises(riskscore.EventsError) as refused:
        riskscore.evaluate(folder, [DRL])
    message = str(refused.value)
    assert (
        "the problems listed below are frame rows of event ids that events.csv lacks: no event "
        "would be left out of the metrics, but those rows would be dropped; add their events to "
        "events.csv or remove those rows, or pass skip_bad_events=True to evaluate the "
        f"{events} events without them\n  "
    ) in message, message
    assert "would leave their events out" not in message, message
    assert "event `ghost`" in message, message

    with pytest.warns(riskscore.BadRowWarning) as caught:
        report = riskscore.evaluate(folder, [DRL], skip_bad_events=True)
    assert sum(report["events"].values()) == events
    [warning] = [str(w.message) for w in caught if w.category is riskscore.BadRowWarning]
    assert "(those events are left out of the metrics)" not in warning, warning
    assert (
        "(each leaves its event out of the metrics, except frames of an event id that events.csv "
        "lacks: only those rows are dropped):\n  "
    ) in warning, warning


def test_read_events_skip_bad_says_frames_of_an_unknown_id_leave_no_event_out(tmp_path):
    folder = folder_with_frames_of_an_unknown_id(tmp_path / "folder")
    count = len((folder / "events.csv").read_text().splitlines()) - 1
    with pytest.warns(riskscore.BadRowWarning) as caught:
        events, _frames = riskscore.read_events(folder, skip_bad=True)
    assert events.num_rows == count
    [warning] = [str(w.message) for w in caught if w.category is riskscore.BadRowWarning]
    assert "(those events are left out)" not in warning, warning
    assert (
        "(each leaves its event out, except frames of an event id that events.csv lacks: only "
        "those rows are dropped)"
    ) in warning, warning
