"""The evaluation harness (ALGORITHM.md section 8) and its baselines."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from conftest import SHARED_SKIP_REASON
from splicer.evaluation.baselines import generic_dtw_frames, uniform_frames
from splicer.evaluation.evaluate import METHODS, METRICS, evaluate, main, summarize, to_markdown
from splicer.rig.roles import find_roles
from splicer.evaluation.separate import separate
from splicer.evaluation.synth import make_gesture_take


@pytest.fixture(scope="module")
def short_take():
    return make_gesture_take(8, 30, np.random.default_rng(7))


@pytest.fixture(scope="module")
def runs(short_take):
    return evaluate([short_take], seeds=1)


@pytest.fixture(scope="module")
def table(runs):
    return summarize(runs)


def test_table_has_every_method_and_metric(runs, table):
    assert isinstance(table, pd.DataFrame)
    assert list(table.index) == list(METHODS)
    for label, _ in METRICS.values():
        assert label in table.columns and f"{label} worst" in table.columns
    assert len(runs) == len(METHODS)
    assert set(runs.columns) >= {"take", "seed", "method", *METRICS}


def test_oracle_is_exact(table):
    assert table.loc["oracle", "align mean (frames)"] < 1e-6
    assert table.loc["oracle", "within 1 frame (%)"] == 100.0
    assert table.loc["oracle", "finger error (deg)"] < 1.5  # only the 0.5 deg capture noise remains


def test_no_alignment_is_worse_than_oracle(table):
    assert table.loc["no alignment", "finger error (deg)"] > table.loc["oracle", "finger error (deg)"] + 1.0
    assert np.isnan(table.loc["no alignment", "align mean (frames)"])


def test_full_method_fixed_ends_beats_uniform_scaling(table):
    # the paper's idealised setting (both takes start and end together, as the separation makes them);
    # measured on this take: 1.06 frames and 0.52 deg, uniform scaling 23.3 frames and 5.3 deg
    full, unif = table.loc["full, fixed ends"], table.loc["uniform scaling"]
    assert full["align mean (frames)"] < 1.5 and unif["align mean (frames)"] > 15.0
    assert full["finger error (deg)"] < 0.8 and unif["finger error (deg)"] > 4.0
    assert full["uncovered (%)"] == 0.0


def test_full_method_beats_uniform_scaling(table):
    # the default splice (ends="auto"): open ends mislocated this 8 s take (seed 0: the right side
    # covered body frames 0-22 only, 60.7 frames of error); auto does not trust an overlap far
    # shorter than two takes of about the same length allow, and aligns them end to end
    full, unif = table.loc["full, smooth time map"], table.loc["uniform scaling"]
    assert full["align mean (frames)"] < 1.5 and unif["align mean (frames)"] > 15.0
    assert full["finger error (deg)"] < 0.8 and unif["finger error (deg)"] > 4.0
    assert full["uncovered (%)"] < 1.0


def test_uncovered_frames_are_scored_with_the_nearest_covered_frame():
    from splicer.evaluation.evaluate import _alignment_scores

    truth = np.arange(10, dtype=np.float64) * 2.0  # hands frame 2i for body frame i
    hf = truth.copy()
    hf[:3] = np.nan  # uncovered: held at hands frame 6 (body frame 3), errors 3, 2, 1
    hf[8:] = np.nan  # held at hands frame 14 (body frame 7), errors 1, 2
    sc = _alignment_scores({"left": hf, "right": truth}, truth)
    assert sc["uncovered"] == pytest.approx(25.0)  # 5 of 20 frames
    assert sc["align_mean"] == pytest.approx(9.0 / 20.0) and sc["align_max"] == 3.0
    assert sc["within_1"] == pytest.approx(85.0) and sc["within_3"] == 100.0
    none = _alignment_scores({"left": np.full(10, np.nan)}, truth)  # nothing covered: infinitely wrong
    assert none["uncovered"] == 100.0 and none["align_mean"] == np.inf and none["within_3"] == 0.0


def test_worst_is_beside_the_mean():
    runs = pd.DataFrame([
        {"take": "t", "seed": s, "method": "oracle", **{k: float(s) for k in METRICS}} for s in range(3)])
    t = summarize(runs)
    assert t.loc["oracle", "align mean (frames)"] == 1.0
    assert t.loc["oracle", "align mean (frames) worst"] == 2.0  # larger error is worse
    assert t.loc["oracle", "within 1 frame (%) worst"] == 0.0  # smaller share is worse
    md = to_markdown(t)
    assert md.count("\n") == 3 and md.startswith("| method |")


def test_uniform_frames_end_points():
    f = uniform_frames(11, 21)
    assert f[0] == 0 and f[-1] == 20 and np.allclose(np.diff(f), 2.0)


def test_generic_dtw_recovers_identity(short_take):
    """Body against itself (same rate, no warp): the generic DTW is the diagonal."""
    roles = find_roles(short_take.skeleton)
    hf = generic_dtw_frames(short_take, short_take, roles["right"], roles["right"], roles.up)
    assert np.abs(hf - np.arange(short_take.n_frames)).mean() < 0.5


def test_inputs_unchanged(short_take):
    before = short_take.channels.copy()
    sep = separate(short_take, rng=np.random.default_rng(3))
    evaluate([short_take], seeds=1, methods=("oracle", "uniform scaling"))
    assert np.array_equal(short_take.channels, before)
    assert sep.body.n_frames == short_take.n_frames


def test_cli_falls_back_to_synthetic(tmp_path, capsys, monkeypatch):
    import splicer.evaluation.evaluate as ev

    monkeypatch.setattr(ev, "SHARED_ZEGGS", tmp_path / "absent")
    out = tmp_path / "acc"
    assert main(["--seeds", "1", "--synthetic-seconds", "6", "--out", str(out)]) == 0
    cap = capsys.readouterr()
    assert "SYNTHETIC" in cap.out and "seed 0" in cap.err
    assert "full, smooth time map" in cap.out
    csv = pd.read_csv(out.with_suffix(".csv"), index_col=0)
    assert list(csv.index) == list(METHODS)
    assert "| oracle |" in out.with_suffix(".md").read_text()


def test_cli_splice_options_reach_the_plain_protocol(tmp_path, capsys, monkeypatch):
    """--splice-option applies to the plain protocol too (it used to be read by the scenarios only,
    and silently ignored here): a bad value is refused by the splice, a good one is named in the header."""
    import splicer.evaluation.evaluate as ev

    monkeypatch.setattr(ev, "SHARED_ZEGGS", tmp_path / "absent")
    assert main(["--seeds", "1", "--synthetic-seconds", "6", "--splice-option", "ends=sideways"]) == 1
    assert "ends" in capsys.readouterr().err
    assert main(["--seeds", "1", "--synthetic-seconds", "6", "--splice-option", "pass1_arms=each"]) == 0
    assert "Splice options for every splice method: {'pass1_arms': 'each'}" in capsys.readouterr().out
    assert main(["--seeds", "1", "--splice-option", "noequals"]) == 1
    assert "needs KEY=VALUE" in capsys.readouterr().err


def test_cli_bad_path(capsys, tmp_path):
    assert main([str(tmp_path / "nope.bvh"), "--seeds", "1"]) == 1
    assert "no such file" in capsys.readouterr().err


@pytest.mark.shared
@pytest.mark.slow
def test_zeggs_one_seed(shared_motions):
    zeggs = shared_motions / "zeggs"
    if not any(zeggs.glob("*.bvh")):
        pytest.skip(SHARED_SKIP_REASON)
    from splicer.io.bvh import read_bvh

    take = read_bvh(sorted(zeggs.glob("*.bvh"))[0])
    t = summarize(evaluate([take], seeds=1, methods=("oracle", "uniform scaling", "full, smooth time map")))
    assert t.loc["oracle", "finger error (deg)"] < 1.5
    assert t.loc["full, smooth time map", "align mean (frames)"] < t.loc["uniform scaling", "align mean (frames)"]
    assert t.loc["full, smooth time map", "finger error (deg)"] < t.loc["uniform scaling", "finger error (deg)"]


def test_cli_scenarios(tmp_path, capsys, monkeypatch):
    import splicer.evaluation.evaluate as ev

    monkeypatch.setattr(ev, "SHARED_ZEGGS", tmp_path / "absent")
    out = tmp_path / "sc"
    assert main(["--scenario", "extra+pause-body", "--scenario", "rate", "--seeds", "2", "--seed0", "100",
                 "--synthetic-seconds", "12", "--out", str(out)]) == 0
    cap = capsys.readouterr()
    assert "### extra+pause-body" in cap.out and "### rate" in cap.out
    assert "extra+pause-body / synthetic / seed 101" in cap.err
    runs = pd.read_csv(out.parent / "sc_runs.csv")
    assert set(runs["scenario"]) == {"extra+pause-body", "rate"} and set(runs["seed"]) == {100, 101}
    assert {"align_mean_s", "align_p95_s", "align_mean_f", "finger_deg", "flag_bad", "flag_good", "unc_found"} <= set(runs.columns)
    assert (runs.loc[runs["method"] == "oracle", "align_mean_s"] < 1e-9).all()
    csv = pd.read_csv(out.with_suffix(".csv"))
    assert {"scenario", "method", "align mean (s)", "align mean (s) worst"} <= set(csv.columns)
    # tabulate the runs again from the CSV, one scenario only
    assert main(["--runs-csv", str(out.parent / "sc_runs.csv"), "--scenario", "rate"]) == 0
    cap = capsys.readouterr()
    assert "### rate" in cap.out and "### extra+pause-body" not in cap.out
    assert main(["--runs-csv", str(tmp_path / "none.csv")]) == 1
    assert "no such file" in capsys.readouterr().err
    # dump the separations as files
    assert main(["--scenario", "short", "--seeds", "1", "--synthetic-seconds", "12", "--dump", str(tmp_path / "d")]) == 0
    capsys.readouterr()
    folder = tmp_path / "d" / "synthetic" / "short" / "seed0"
    assert sorted(p.name for p in folder.iterdir()) == ["body.bvh", "hands.bvh", "truth.csv"]
    truth = pd.read_csv(folder / "truth.csv")
    assert truth["hands_frame"].isna().any() and truth["hands_frame"].notna().sum() > 100
    assert main(["--scenario", "nope", "--seeds", "1"]) == 1
    assert "unknown scenario 'nope'" in capsys.readouterr().err
    assert main(["--scenario", "base", "--seeds", "1", "--synthetic-seconds", "6", "--splice-option", "theta=sideways"]) == 1
    assert "theta must be one of" in capsys.readouterr().err
    assert main(["--scenario", "base", "--seeds", "1", "--splice-option", "merge"]) == 1
    assert "KEY=VALUE" in capsys.readouterr().err
