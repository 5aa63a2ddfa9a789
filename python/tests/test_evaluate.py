"""riskscore.evaluate returns what `riskctl evaluate --json` prints."""
import json

import pytest

import riskscore
from conftest import MODELS, NGSIM_SAFE, ngsim_with_a_bad_frame

DRL, MSRA = MODELS / "drl-default.rsk", MODELS / "msra-default.rsk"


@pytest.fixture(scope="module")
def simulated(riskctl, tmp_path_factory):
    """A small simulated folder with crash, near-crash and safe events (metrics defined)."""
    folder = tmp_path_factory.mktemp("sim") / "events"
    riskctl("simulate", "--out", folder, "--events", 60, "--seed", 7)
    return folder


def cli(riskctl, folder, *args):
    return json.loads(riskctl("evaluate", "--events", folder, "--json", *args).stdout)


def test_simulated_folder_matches_the_cli(riskctl, simulated):
    expected = cli(riskctl, simulated, "--model", DRL, "--model", MSRA)
    ours = riskscore.evaluate(simulated, [DRL, riskscore.Model.load(MSRA)])
    assert ours == expected
    assert expected["events"]["crash"] > 0
    assert [m["name"] for m in ours["methods"]][:2] == ["DRL", "MSRA"]


def test_thresholds_match_the_cli(riskctl, simulated):
    expected = cli(riskctl, simulated, "--model", f"MINE={DRL}", "--threshold", "2.5",
                   "--threshold", "TTC2D=-3")
    ours = riskscore.evaluate(simulated, {"MINE": DRL}, thresholds={"MINE": 2.5, "TTC2D": -3})
    assert ours == expected
    assert riskscore.evaluate(simulated, [DRL], thresholds=None)["operating_points"] == []


def test_real_safe_driving_matches_the_cli(riskctl):
    expected = cli(riskctl, NGSIM_SAFE, "--model", DRL, "--threshold", "2.0")
    assert riskscore.evaluate(NGSIM_SAFE, DRL, thresholds=2.0) == expected


def test_errors_name_the_problem(simulated, tmp_path):
    with pytest.raises(riskscore.ModelError, match='no row named "NOPE"'):
        riskscore.evaluate(simulated, [DRL], thresholds={"NOPE": 1.0})
    with pytest.raises(riskscore.ModelError, match="missing.rsk: cannot read: No such file"):
        riskscore.evaluate(simulated, [tmp_path / "missing.rsk"])
    with pytest.raises(riskscore.EventsError, match="event folder"):
        riskscore.evaluate(tmp_path, [DRL])


def test_a_threshold_word_that_is_not_one_is_named(simulated):
    """Not a pyo3 TypeError listing enum variants: a ModelError naming the value (and row)."""
    with pytest.raises(riskscore.ModelError, match="""thresholds: 'Default' is not a number, "default", "none" or None"""):
        riskscore.evaluate(simulated, [DRL], thresholds="Default")
    with pytest.raises(riskscore.ModelError, match="""thresholds\\['TTC2D'\\]: '1.5' is not a number"""):
        riskscore.evaluate(simulated, [DRL], thresholds={"TTC2D": "1.5"})


def test_a_bool_threshold_is_not_taken_as_one(simulated):
    """thresholds=True (meant as "use the defaults"?) would silently evaluate every model at 1.0."""
    with pytest.raises(riskscore.ModelError, match="thresholds: True is not a number"):
        riskscore.evaluate(simulated, [DRL], thresholds=True)
    with pytest.raises(riskscore.ModelError, match=r"thresholds\['DRL'\]: False is not a number"):
        riskscore.evaluate(simulated, [DRL], thresholds={"DRL": False})


def test_a_folder_with_bad_rows_is_refused_pointing_at_the_problems_below(tmp_path):
    """The problems follow the message (riskctl prints them before it: "listed above")."""
    folder = ngsim_with_a_bad_frame(tmp_path / "bad")
    with pytest.raises(riskscore.EventsError, match=r"problems listed below .*skip_bad_events=True[^\n]*\n  .*frames.csv:6:"):
        riskscore.evaluate(folder, [DRL])
    with pytest.warns(riskscore.BadRowWarning, match="frames.csv:6:"):
        assert riskscore.evaluate(folder, [DRL], skip_bad_events=True)["events"]["safe"] == 375


def test_a_loaded_model_is_evaluated_as_loaded(simulated, tmp_path):
    """Not re-read from its path: the file replaced since (a retrained model written over it),
    or a Model made from bytes, still evaluates the blob the Model holds."""
    copy = tmp_path / "drl-default.rsk"
    copy.write_bytes(DRL.read_bytes())
    model = riskscore.Model.load(copy)
    copy.write_bytes(MSRA.read_bytes())
    expected = riskscore.evaluate(simulated, [DRL])
    assert riskscore.evaluate(simulated, [model]) == expected
    from_bytes = riskscore.Model.from_bytes(DRL.read_bytes())
    assert riskscore.evaluate(simulated, {"DRL": from_bytes}) == expected
    both = riskscore.evaluate(simulated, [model, DRL], thresholds="none")
    assert [m["name"] for m in both["methods"]][:2] == ["drl-default#1", "drl-default#2"]


def test_notes_are_neither_listed_nor_counted_as_problems(tmp_path):
    """evaluate: a note (a hole in the frames) warns on its own, not as a problem whose event is
    left out of the metrics; a refusal lists it apart from the problems."""
    import warnings

    from conftest import folder_with_a_problem_and_a_note

    folder = folder_with_a_problem_and_a_note(tmp_path / "folder")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        report = riskscore.evaluate(folder, [DRL], skip_bad_events=True)
    assert report["events"]["safe"] == 1
    bad = [str(w.message) for w in caught if w.category is riskscore.BadRowWarning]
    notes = [str(w.message) for w in caught if w.category is UserWarning]
    assert len(bad) == 1 and len(notes) == 1, caught
    assert bad[0].startswith("1 problem(s)") and bad[0].count("\n  ") == 1
    assert "Safe" in bad[0] and "frames jump" not in bad[0]
    assert "frames jump" in notes[0]
    with pytest.raises(riskscore.EventsError) as refused:
        riskscore.evaluate(folder, [DRL])
    problems, _, notes_part = str(refused.value).partition("\nnotes (they leave nothing out):\n")
    assert "Safe" in problems and "frames jump" not in problems
    assert "frames jump" in notes_part


def test_a_model_path_with_an_equals_sign_is_a_path_not_a_name(riskctl, simulated, tmp_path,
                                                                monkeypatch):
    """`--model` reads `NAME=FILE` when no path separator comes before the first "="; a relative
    path like a sweep's `lr=0.01/drl.rsk` given to evaluate is a file (names come from a dict),
    as Model.load takes it."""
    (tmp_path / "lr=0.01").mkdir()
    (tmp_path / "lr=0.01" / "drl.rsk").write_bytes(DRL.read_bytes())
    (tmp_path / "seed=3.rsk").write_bytes(MSRA.read_bytes())
    monkeypatch.chdir(tmp_path)
    expected = cli(riskctl, simulated, "--model", DRL, "--model", MSRA)
    assert riskscore.evaluate(simulated, ["lr=0.01/drl.rsk", "seed=3.rsk"]) == expected
    named = riskscore.evaluate(simulated, {"MINE": "lr=0.01/drl.rsk"})
    assert named == cli(riskctl, simulated, "--model", f"MINE={DRL}")


@pytest.mark.parametrize("name", ["a=b", "runs/a", "runs\\a", ""])
def test_a_row_name_the_spec_cannot_carry_is_refused_naming_it(simulated, name):
    """Not "cannot read b=/.../drl-default.rsk" about a file the caller never named."""
    with pytest.raises(riskscore.ModelError, match=f"row name {name!r}".replace("\\", "\\\\")):
        riskscore.evaluate(simulated, {name: DRL})


@pytest.mark.parametrize("models, named", [(None, "NoneType"), (3, "int"), (b"m.rsk", "bytes")])
def test_models_of_the_wrong_type_say_what_is_expected(simulated, models, named):
    """models=None raised a bare "TypeError: 'NoneType' object is not iterable"."""
    with pytest.raises(TypeError, match=rf"models: expected a model file's path, a riskscore\.Model, "
                                        rf"a list of them or a {{row name: path or Model}} dict, "
                                        rf"not {named} \(models=\(\) evaluates"):
        riskscore.evaluate(simulated, models)


@pytest.mark.parametrize("models", [[None], [DRL, 3], {"MINE": None}])
def test_a_model_of_the_wrong_type_in_a_list_or_dict_is_named(simulated, models):
    with pytest.raises(TypeError, match=r"models: (None|3) \((NoneType|int)\) is not a model: give a "
                                        r"model file's path \(str or os\.PathLike\) or a riskscore\.Model"):
        riskscore.evaluate(simulated, models)


def test_a_numpy_threshold_is_taken_as_a_number(simulated):
    """np.float32 works at runtime (a threshold picked from a float32 score array is one); the
    type hints said float only, which type checkers held against it."""
    import numpy as np

    at = riskscore.evaluate(simulated, [DRL], thresholds=2.5)["operating_points"]
    assert riskscore.evaluate(simulated, [DRL], thresholds=np.float32(2.5))["operating_points"] == at
    assert riskscore.evaluate(simulated, [DRL], thresholds={"DRL": np.float32(2.5)})[
        "operating_points"] == at


def test_events_without_a_sequence_warn_as_riskctl_lists_them(riskctl, tmp_path):
    """A valid event the preparation rules turn into no sequence (here a safe event of 0.9 s,
    under the 2 s a safe sequence needs) is left out of the metrics. riskctl evaluate lists it on
    stderr; evaluate said nothing of it (only the counts in `events` were one short). It warns
    now, with riskctl's line."""
    import warnings

    import pyarrow.compute as pc

    events, frames = riskscore.read_events(NGSIM_SAFE)
    two = events.slice(0, 2)
    first, second = two.column("event_id").to_pylist()
    rows = pc.indices_nonzero(pc.equal(frames.column("event_id"), first)).to_pylist()
    others = pc.indices_nonzero(pc.equal(frames.column("event_id"), second)).to_pylist()
    folder = tmp_path / "short"
    riskscore.write_events(folder, two, frames.take(rows + others[:10]))
    listed = [
        line.strip()
        for line in riskctl("evaluate", "--events", folder, "--json").stderr.splitlines()
        if line.startswith("  event ")
    ]
    assert len(listed) == 1 and f"`{second}`" in listed[0], listed
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        report = riskscore.evaluate(folder, [DRL])
    assert report["events"]["safe"] == 1
    said = [str(w.message) for w in caught if w.category is UserWarning]
    assert len(said) == 1, [str(w.message) for w in caught]
    assert "1 event(s) yield no sequence" in said[0] and listed[0] in said[0], said[0]
