"""riskscore.Model: scores equal to `riskctl score` (int8 DRL as on the ECU), info, errors."""
import re

import numpy as np
import pyarrow.parquet as pq
import pytest

import riskscore
from conftest import MODELS, NGSIM_SAFE, PAIR_COLUMNS


@pytest.mark.parametrize("file,column", [("drl-default.rsk", "DRL"), ("msra-default.rsk", "MSRA")])
def test_scores_match_riskctl_score_bit_for_bit(riskctl, tmp_path, ngsim_frames, file, column):
    out = tmp_path / "scores.parquet"
    riskctl("score", "--model", MODELS / file, "--events", NGSIM_SAFE, "--out", out)
    expected = pq.read_table(out).column(column).to_numpy().astype(np.float32)
    model = riskscore.Model.load(MODELS / file)
    scores = model.score(ngsim_frames)
    assert scores.dtype == np.float32 and scores.shape == (ngsim_frames.num_rows,)
    assert np.array_equal(scores.view(np.uint32), expected.view(np.uint32))


@pytest.mark.parametrize("file,column", [("drl-default.rsk", "DRL"), ("msra-default.rsk", "MSRA")])
def test_in_domain_matches_riskctl_score(riskctl, tmp_path, ngsim_frames, file, column):
    out = tmp_path / "scores.parquet"
    riskctl("score", "--model", MODELS / file, "--events", NGSIM_SAFE, "--out", out)
    expected = pq.read_table(out).column(f"{column}_in_domain").to_numpy() == 1
    model = riskscore.Model.load(MODELS / file)
    flags = model.in_domain(ngsim_frames)
    assert flags.dtype == np.bool_ and flags.shape == (ngsim_frames.num_rows,)
    assert np.array_equal(flags, expected)
    if column == "DRL":
        # The shipped DRL blends in, and outside falls back to, the kinematic score; some real
        # frames are outside.
        assert model.info["domain_policy"] == "blend"
        assert 0 < (~flags).sum() < flags.size


def test_info_matches_inspect_model(riskctl):
    for file, kind in (("drl-default.rsk", "DRL"), ("msra-default.rsk", "MSRA")):
        model = riskscore.Model.load(MODELS / file)
        text = riskctl("inspect-model", MODELS / file).stdout
        info = model.info
        assert info["kind"] in text and info["kind"].upper().startswith(kind)
        threshold = float(re.search(r"default threshold (\S+)", text).group(1))
        assert info["default_threshold"] == pytest.approx(threshold, rel=0, abs=1e-6)
        assert f"{info['payload_bytes']} bytes" in text
        assert f"{info['payload_crc32']:#010x}" in text
        assert info["int8"] == (kind == "DRL")
        assert len(info["inputs"]) > 0
        blend = re.search(r"blend +(\S+) \* model", text)
        if kind == "DRL":
            # The shipped DRL blends; inspect-model prints the weight to one decimal.
            assert info["domain_policy"] == "blend"
            assert info["blend_network_weight"] == pytest.approx(float(blend.group(1)), abs=0.05)
        else:
            assert blend is None and info["blend_network_weight"] is None
    assert "model" in repr(model).lower()


def test_from_bytes_scores_like_load(ngsim_frames):
    loaded = riskscore.Model.load(MODELS / "drl-default.rsk")
    copy = riskscore.Model.from_bytes(loaded.to_bytes())
    assert copy.path is None and loaded.path.endswith("drl-default.rsk")
    pairs = ngsim_frames.slice(0, 1000)
    assert np.array_equal(copy.score(pairs), loaded.score(pairs))


def test_bad_blobs_are_refused_naming_the_file(tmp_path):
    blob = (MODELS / "drl-default.rsk").read_bytes()
    truncated = tmp_path / "cut.rsk"
    truncated.write_bytes(blob[: len(blob) // 2])
    with pytest.raises(riskscore.ModelError, match="cut.rsk"):
        riskscore.Model.load(truncated)
    flipped = bytearray(blob)
    flipped[-1] ^= 0xFF
    with pytest.raises(riskscore.ModelError, match="model bytes"):
        riskscore.Model.from_bytes(bytes(flipped))
    with pytest.raises(FileNotFoundError, match="missing.rsk: cannot read"):
        riskscore.Model.load(tmp_path / "missing.rsk")
    with pytest.raises(IsADirectoryError, match="cannot read"):
        riskscore.Model.load(tmp_path)


@pytest.mark.parametrize("bom", [b"", b"\xef\xbb\xbf"])
def test_a_training_checkpoint_is_named_as_riskctl_names_it(riskctl, tmp_path, bom):
    """Model.load("run/drl.json") said 'not a model blob: magic [7b, 0a, 20, 20]'; riskctl names
    a checkpoint and the command that exports its blob. Python now says the same words (the
    detection and the message are riskscore-eval's, shared with riskctl)."""
    import subprocess

    checkpoint = tmp_path / "drl.json"
    checkpoint.write_bytes(
        bom + b'{\n  "format": "riskscore-checkpoint",\n  "version": 3,\n  "model": {}\n}\n'
    )
    with pytest.raises(riskscore.ModelError) as raised:
        riskscore.Model.load(checkpoint)
    message = str(raised.value)
    assert "it is a training checkpoint" in message, message
    assert f"riskctl export-model {checkpoint} --out MODEL.rsk" in message, message
    with pytest.raises(subprocess.CalledProcessError) as cli:
        riskctl("score", "--model", checkpoint, "--events", tmp_path, "--out", tmp_path / "s.csv")
    assert cli.value.stderr.strip() == f"riskctl: error: {message}"


def test_bad_rows_score_nan_and_strict_raises(ngsim_frames):
    model = riskscore.Model.load(MODELS / "drl-default.rsk")
    pairs = ngsim_frames.select(PAIR_COLUMNS).slice(0, 50).to_pandas()
    pairs.loc[7, "length_j"] = -1.0
    with pytest.warns(riskscore.BadRowWarning, match="row 7 column length_j"):
        scores = model.score(pairs)
    assert np.isnan(scores[7]) and np.isfinite(np.delete(scores, 7)).all()
    with pytest.raises(riskscore.BadRowError, match="row 7 column length_j"):
        model.score(pairs, strict=True)
    with pytest.raises(riskscore.ColumnError, match="hy_i"):
        model.score(pairs.drop(columns=["hy_i"]))


def test_info_docstring_shows_a_kind_info_returns():
    """help(Model.info) gives an example of ``kind``: it is a value ``info`` really returns."""
    kind = riskscore.Model.load(MODELS / "drl-default.rsk").info["kind"]
    assert f'``kind`` (e.g. "{kind}")' in riskscore.Model.info.__doc__


def test_a_model_pickles_as_its_blob(ngsim_frames):
    """multiprocessing, joblib and Spark UDF closures pickle the Model they use."""
    import copy
    import pickle

    model = riskscore.Model.load(MODELS / "drl-default.rsk")
    again = pickle.loads(pickle.dumps(model))
    assert again.to_bytes() == model.to_bytes() and again.path is None
    pairs = ngsim_frames.slice(0, 500)
    assert np.array_equal(again.score(pairs), model.score(pairs))
    assert copy.deepcopy(model).to_bytes() == model.to_bytes()


def test_scores_are_a_read_only_view_as_the_docstring_says(ngsim_frames):
    """`risk[mask] = 0` on the zero-copy scores fails: help(Model.score) must say so."""
    scores = riskscore.Model.load(MODELS / "drl-default.rsk").score(ngsim_frames.slice(0, 10))
    assert not scores.flags.writeable
    assert "read-only" in " ".join(riskscore.Model.score.__doc__.split())
    scores.copy()[0] = 0.0


@pytest.mark.parametrize("argument", [str(MODELS / "drl-default.rsk"), MODELS / "drl-default.rsk",
                                      b"RSKM"])
def test_the_constructor_points_at_load_instead_of_building_a_broken_model(argument):
    """Model(path) is the natural guess; it used to return an object that failed on first use
    with "'str' object has no attribute '_score'"."""
    with pytest.raises(TypeError, match=r"Model\.load\(path\).*Model\.from_bytes\(blob\)"):
        riskscore.Model(argument)


def test_a_file_that_is_no_blob_is_refused_from_its_header(tmp_path):
    """Model.load read the whole file before looking at the magic: a table of pairs of some GB
    passed by mistake went into memory first, and a pipe was read until its writer closed it.
    Here the writer keeps a pipe open for 20 s after the first bytes; the header decides."""
    import os
    import subprocess
    import time

    pipe = tmp_path / "pairs.parquet"
    os.mkfifo(pipe)
    writer = subprocess.Popen(
        ["sh", "-c", 'exec 3>"$1"; printf "PAR1%032d" 0 >&3; sleep 20', "sh", str(pipe)]
    )
    try:
        started = time.monotonic()
        with pytest.raises(riskscore.ModelError,
                           match=r"pairs\.parquet: not a valid model blob: not a model blob: magic"):
            riskscore.Model.load(pipe)
        assert time.monotonic() - started < 10
    finally:
        writer.kill()
        writer.wait()


def _score_sum(model, frames):
    return float(np.nansum(model.score(frames))), riskscore.ssm(frames).num_rows


@pytest.mark.filterwarnings("ignore:This process .* is multi-threaded:DeprecationWarning")
def test_a_forked_worker_scores_after_its_parent_did(ngsim_frames):
    """multiprocessing's "fork" start method (Linux's default before Python 3.14): a child
    forked after the parent scored inherited rayon's global pool without its threads and waited
    for them forever on its first Model.score. The kernels now run on a pool per process."""
    import multiprocessing

    model = riskscore.Model.load(MODELS / "drl-default.rsk")
    expected = _score_sum(model, ngsim_frames)  # the parent's pool is up before the fork
    pool = multiprocessing.get_context("fork").Pool(2)
    try:
        pending = pool.starmap_async(_score_sum, [(model, ngsim_frames)] * 2, chunksize=1)
        assert pending.get(timeout=60) == [expected] * 2
    finally:
        pool.terminate()
        pool.join()
