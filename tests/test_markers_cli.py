"""Real markers in the splice and the alignment-only ``splice-markers`` command."""

import json

import numpy as np

from splicer.defaults import COVERAGE_EDGE_S
from splicer.stages.coverage import coverage_edges
import pytest

c3d = pytest.importorskip("c3d")

from splicer.align.passes import hold_ends  # noqa: E402
from splicer.io.bvh import write_bvh  # noqa: E402
from splicer.evaluation.marker_synth import skin_markers  # noqa: E402
from splicer.markers_cli import main  # noqa: E402
from splicer.evaluation.scenario_eval import ranges_mask  # noqa: E402
from splicer.evaluation.separate import separate  # noqa: E402
from splicer.evaluation.synth import make_gesture_take  # noqa: E402
from splicer.io.trajectory_writers import write_c3d  # noqa: E402


@pytest.fixture(scope="module")
def session(tmp_path_factory):
    """A separated synthetic take; each session's markers at its own rate, as C3D."""
    d = tmp_path_factory.mktemp("markers")
    take = make_gesture_take(8.0, 30.0, np.random.default_rng(5))
    sep = separate(take, rng=np.random.default_rng(6))
    rng = np.random.default_rng(7)
    hands = skin_markers(sep.hands, rng=rng, fps=100.0, noise_mm=(0, 0), gaps_per_minute=0, source="hands.c3d")
    body = skin_markers(sep.body, rng=rng, fps=50.0, gaps_per_minute=20.0, source="body.c3d")
    write_c3d(hands, d / "hands.c3d")
    write_c3d(body, d / "body.c3d")
    write_bvh(sep.body, d / "body.bvh")
    write_bvh(sep.hands, d / "hands.bvh")
    return d, sep, hands, body


def test_splice_markers_retimes_hands_onto_the_body_timeline(session, capsys):
    d, sep, hands, body = session
    assert main([str(d / "body.c3d"), str(d / "hands.c3d"), "--report", str(d / "r.json"),
                 "-o", str(d / "retimed.c3d")]) == 0
    assert (f"Aligned {hands.n_frames} hands frames at 100 Hz to {body.n_frames} body frames at 50 Hz"
            in capsys.readouterr().out)
    with open(d / "retimed.c3d", "rb") as f, pytest.warns(UserWarning, match="No analog"):  # by the library itself
        r = c3d.Reader(f)
        frames = np.stack([p[:, :4].copy() for _, p, _ in r.read_frames()])
        frames[frames[..., 3] < 0] = np.nan  # residual -1: missing (C3D convention)
        frames = frames[..., :3]
        assert r.point_rate == 50.0 and frames.shape[0] == body.n_frames == r.last_frame - r.first_frame + 1
        assert [s.strip() for s in r.point_labels] == list(hands.labels)
    text = (d / "r.json").read_text()
    assert "NaN" not in text and "Infinity" not in text  # strict JSON: an uncovered frame is null
    rep = json.loads(text)
    assert sorted(rep["sides"]) == ["left", "right"]
    for side, s in rep["sides"].items():
        tm = np.array(s["hands_frame"], dtype=np.float64)  # null (NaN): a body frame the hands do not cover
        cov = np.isfinite(tm)
        assert len(tm) == body.n_frames and np.all(np.diff(tm[cov]) >= 0)
        assert not cov.any() or ranges_mask(s["uncovered"], body.n_frames).tolist() == (~cov).tolist()
        cols = [k for k, lab in enumerate(hands.labels) if lab.startswith(f"Sim:{side[0].upper()}_")]
        expect = np.stack([[np.interp(tm[cov], np.arange(hands.n_frames), hands.points[:, c, a]) for a in range(3)]
                           for c in cols], axis=-1).transpose(1, 2, 0)
        np.testing.assert_allclose(frames[cov][:, cols], expect, atol=1e-3)  # float32 in the file
        assert np.isnan(frames[~cov][:, cols]).all()  # uncovered: written as missing (residual -1)
        # the time map finds the true timing: body frame i at 50 Hz is body-take time i/50 s; an
        # uncovered frame is scored with the nearest covered hands frame (what the hands would show)
        truth_s = np.interp(np.arange(body.n_frames) / 50.0, np.arange(len(sep.truth)) / 30.0, sep.truth / 60.0)
        assert np.mean(np.abs(hold_ends(tm) / 100.0 - truth_s)) < 3.0 / 30.0  # within 3 frames of the 30 fps take
        assert s["markers"]["body"]["gaps_filled"] and s["markers"]["body"]["marker_set"] == "biomechanics"


def test_splice_markers_flags_the_edges_of_partial_coverage(session, tmp_path):
    """Hands markers cut to the middle half of their session: the body frames outside are
    uncovered, and, as splice reports them, the covered frames next to them are low confidence."""
    import dataclasses

    d, _, hands, body = session
    n = hands.n_frames
    part = dataclasses.replace(hands, points=hands.points[n // 4:3 * n // 4].copy(), source="part.c3d")
    write_c3d(part, tmp_path / "part.c3d")
    assert main([str(d / "body.c3d"), str(tmp_path / "part.c3d"), "--report", str(tmp_path / "r.json"),
                 "-o", str(tmp_path / "o.c3d"), "-q"]) == 0
    rep = json.loads((tmp_path / "r.json").read_text())
    for side, s in rep["sides"].items():
        tm = np.array(s["hands_frame"], dtype=np.float64)
        cov = np.isfinite(tm)
        assert 0 < cov.sum() < 0.75 * len(cov)
        edges = coverage_edges(tm, 50.0)
        assert edges.sum() >= 2 * round(COVERAGE_EDGE_S * 50.0) - 1
        assert ranges_mask(s["low_confidence"], body.n_frames)[edges].all()
    assert any("count as low confidence" in w for w in rep["warnings"])


def test_splice_with_hands_markers(session):
    import splicer.defaults as D
    from splicer.evaluation.evaluate import _alignment_scores
    from splicer.pipeline import splice

    d, sep, hands, body = session
    r = splice(d / "body.bvh", d / "hands.bvh", hands_markers=d / "hands.c3d")
    err = _alignment_scores({s: v.hands_frame for s, v in r.sides.items()}, sep.truth)
    assert err["align_mean"] < 2.0
    side = r.report.to_dict()["sides"]["left"]
    assert side["markers"]["hands"]["path"].endswith("hands.c3d") and "body" not in side["markers"]
    # passes="auto": pass 1 alone on optical markers (defaults.PASSES); "both" runs pass 2 on them
    assert all(v.alignment.pass1 is not None and v.alignment.pass2 is None for v in r.sides.values())
    # optical markers have no root heading: pass 1's position term is the hand-in-forearm signs alone, the
    # body's virtual markers put on the styloids as the optical ones are (0.31.0)
    assert all(v.alignment.pass1.position_weight == D.OPTICAL_SIGN_WEIGHT and v.alignment.pass1.wrist_signs
               for v in r.sides.values())
    both = splice(d / "body.bvh", d / "hands.bvh", hands_markers=d / "hands.c3d", passes="both")
    assert all(v.alignment.pass2 is not None for v in both.sides.values())
    plain = splice(d / "body.bvh", d / "hands.bvh")  # the BVHs' virtual markers keep pass 2
    assert all(v.alignment.pass2 is not None for v in plain.sides.values())
    # against optical markers, the other take's virtual wrist markers sit on the styloids; between
    # BVHs, across the palm
    from splicer.align.wrist import ANATOMICAL, STYLOID

    assert all(v.markers.placed == (STYLOID, "optical") for v in r.sides.values())
    assert all(v.markers.placed == (ANATOMICAL, ANATOMICAL) for v in plain.sides.values())
    ran = [v for v in r.sides.values() if v.wrist is not None]
    assert ran and all(D.WRIST_ROUNDS_MIN <= v.extra["wrist_rounds"] <= D.WRIST_ROUNDS for v in ran)  # hands markers made without noise: rounds until settled
    from splicer.io.config import SpliceConfig

    rigid = splice(d / "body.bvh", d / "hands.bvh", hands_markers=d / "hands.c3d",
                   config=SpliceConfig(markers={"hands": {"derive": "rigid"}}))  # its wrist markers ride on the hand
    assert all(v.markers.placed == (ANATOMICAL, "optical") for v in rigid.sides.values())
    # placed differently (the body's wrist markers across the palm): no signs, and no coordinates, so no term
    assert all(v.alignment.pass1.position_weight == 0.0 and not v.alignment.pass1.wrist_signs
               for v in rigid.sides.values())
    body_optical = splice(d / "body.bvh", d / "hands.bvh", body_markers=d / "body.c3d")
    assert all(v.markers.placed == ("optical", STYLOID) for v in body_optical.sides.values())
    assert all(v.extra.get("wrist_rounds", 1) == 1 for v in body_optical.sides.values())  # 1-2 mm of noise


def test_passes_of():
    from types import SimpleNamespace

    from splicer.options import SpliceOptions
    from splicer.stages.align import passes_of

    optical, virtual = SimpleNamespace(real={"hands": {}}), SimpleNamespace(real={})
    assert passes_of(SpliceOptions(), optical) == "pass1" and passes_of(SpliceOptions(), virtual) == "both"
    for p in ("both", "pass1", "pass2"):
        assert passes_of(SpliceOptions(passes=p), optical) == p == passes_of(SpliceOptions(passes=p), virtual)


def test_cli_flags_pass_markers(session, tmp_path):
    from splicer.cli import main as splice_main

    d, *_ = session
    assert splice_main([str(d / "body.bvh"), str(d / "hands.bvh"), "-o", str(tmp_path / "o.bvh"), "-q",
                        "--hands-markers", str(d / "hands.c3d"), "--body-markers", str(d / "body.c3d"),
                        "--report", str(tmp_path / "r.json")]) == 0
    rep = json.loads((tmp_path / "r.json").read_text())
    assert set(rep["sides"]["right"]["markers"]) == {"body", "hands"}


def test_missing_roles_is_one_line(tmp_path, capsys):
    from splicer.io.trajectories import Trajectories

    t = Trajectories(("A", "B"), np.ones((3, 2, 3)), 100.0)
    write_c3d(t, tmp_path / "a.c3d")
    assert main([str(tmp_path / "a.c3d"), str(tmp_path / "a.c3d"), "-o", str(tmp_path / "o.c3d")]) == 1
    err = capsys.readouterr().err.strip()
    assert err.startswith("splice-markers: error:") and "Labels found: A, B" in err and "\n" not in err


def test_unsided_markers_are_not_used_for_two_sides(session):
    from dataclasses import replace

    from splicer.io.config import SpliceConfig
    from splicer.pipeline import splice

    d, sep, hands, body = session
    cols = [k for k, lab in enumerate(hands.labels) if lab.startswith("Sim:R_")]
    one_arm = replace(hands, labels=tuple(hands.labels[k].replace("R_", "") for k in cols),
                      points=hands.points[:, cols])
    r = splice(d / "body.bvh", d / "hands.bvh", hands_markers=one_arm)
    assert sum("tell no side; not used for the" in w for w in r.report.warnings) == 2
    assert all("markers" not in s.extra for s in r.report.sides.values())
    r = splice(d / "body.bvh", d / "hands.bvh", hands_markers=one_arm, config=SpliceConfig(hands_side="right"))
    assert "markers" in r.report.sides["right"].extra and "markers" not in r.report.sides["left"].extra


@pytest.mark.parametrize("args, words", [
    (["--max-gap", "-1"], "argument --max-gap: '-1': give a positive number of seconds"),
    (["--max-gap", "nan"], "give a positive number of seconds"),
    (["--max-gap", "soon"], "'soon' is not a number of seconds"),
    (["--band", "9" * 100], "band width '99999999999999999999'… is 100 characters long"),
    (["--side", "middle"], "argument --side: invalid choice"),
])
def test_usage_errors_are_one_line(tmp_path, capsys, args, words):
    with pytest.raises(SystemExit) as e:
        main(["b.c3d", "h.c3d", "-o", str(tmp_path / "o.c3d")] + args)
    assert e.value.code == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("splice-markers: error: ") and words in err
    assert err.rstrip().endswith("(see splice-markers --help)")


def test_splice_markers_runs_the_wrist_refinement_on_the_real_capture(shared_motions):
    """The shared Vicon capture aligned to itself re-timed by a known smooth warp (as
    benchmarks/eval_markers.py's real check): the wrist's refinement runs in ``splice-markers`` as
    in ``splice`` (both takes optical: placed alike) and brings the mean error from 1.24 to 0.86
    body frames (measured, 0.21.0; 0.99 with one round: the capture's noise, 0.01-0.03 mm, makes
    up 7e-5 of the hand's motion, so it gets the virtual markers' two rounds)."""
    import splicer.defaults as D
    import dataclasses

    from splicer.align.passes import hold_ends
    from splicer.io.trajectories import read_c3d
    from splicer.markers_cli import align_marker_files, retime

    t = read_c3d(shared_motions / "c3d" / "markers_analogs.c3d")
    m = int((t.n_frames - 1) / t.fps * 120.0) + 1
    u = np.linspace(0.0, 1.0, m)
    src = (u + 0.06 * np.sin(2 * np.pi * u) + 0.03 * np.sin(4 * np.pi * u)) * (t.n_frames - 1)
    h = dataclasses.replace(t, points=retime(t, src, fps=120.0, first_frame=1), fps=120.0, source="warped.c3d")
    truth = np.interp(np.arange(t.n_frames), src, np.arange(m))
    err = {}
    for radius in (0.0, None):
        r = align_marker_files(t, h, **({} if radius is None else {"wrist_radius_s": radius}))
        err[radius] = float(np.mean(np.abs(hold_ends(r.time_maps["right"]) - truth) * t.fps / 120.0))
        side = r.report.to_dict()["sides"]["right"]
        assert ("wrist_shift_frames" in side) is (radius is None)
    assert 0.0 < side["wrist_noise_share"] < D.WRIST_ROUNDS_NOISE_SHARE_MAX
    assert D.WRIST_ROUNDS_MIN <= side["wrist_rounds"] <= D.WRIST_ROUNDS  # the quiet markers' rounds until settled (2 here)
    assert err[None] < 0.75 * err[0.0], err  # measured 0.86 against 1.24 (one round: 0.99)


def test_noisy_optical_markers_leave_the_wrist_refinement_out(session, monkeypatch):
    """The markers' noise is estimated and reported; where it makes up more than
    WRIST_NOISE_SHARE_MAX of the hand's motion in the forearm, the map stays as the passes made it."""
    import splicer.defaults as D
    from splicer.pipeline import splice

    d, sep, hands, body = session
    kw = dict(hands_markers=d / "hands.c3d", body_markers=d / "body.c3d")
    r = splice(d / "body.bvh", d / "hands.bvh", **kw)
    # both takes optical, placed alike: pass 1's position term is the hand-in-forearm signs alone (0.31.0)
    assert all(v.alignment.pass1.position_weight == D.OPTICAL_SIGN_WEIGHT and v.alignment.pass1.wrist_signs
               for v in r.sides.values())
    side = r.report.to_dict()["sides"]["left"]
    noise = side["markers"]["body"]["noise"]
    assert set(noise) == {"p1", "p2", "p3", "p4", "shoulder"}
    assert 1.0 <= noise["p1"] <= 2.0 and noise["p3"] < noise["p1"]  # 1-2 mm drawn; p3 averages four markers
    assert side["markers"]["hands"]["noise"]["p1"] < 0.05  # made without noise: the motion's own jerk leaves hundredths of a mm
    shares = {s: v.extra["wrist_noise_share"] for s, v in r.sides.items()}
    assert all(x > 0.0 for x in shares.values()) and min(shares.values()) < D.WRIST_NOISE_SHARE_MAX, shares
    for s, v in r.sides.items():  # measured: left 0.35 (its hand moves little in the forearm), right 0.09
        assert (v.wrist is None) == (shares[s] > D.WRIST_NOISE_SHARE_MAX)
    assert sum("wrist's refinement left out" in w for w in r.report.warnings) == sum(
        x > D.WRIST_NOISE_SHARE_MAX for x in shares.values())
    monkeypatch.setattr(D, "WRIST_NOISE_SHARE_MAX", min(shares.values()) / 2)
    left_out = splice(d / "body.bvh", d / "hands.bvh", **kw)
    assert all(v.wrist is None and v.extra["wrist_noise_share"] == pytest.approx(shares[s], abs=1e-3)
               for s, v in left_out.sides.items())
    assert sum("wrist's refinement left out" in w for w in left_out.report.warnings) == len(left_out.sides)
    off = splice(d / "body.bvh", d / "hands.bvh", wrist_radius_s=0.0, **kw)  # the stage switched off: the same maps
    for s in off.sides:
        np.testing.assert_array_equal(left_out.sides[s].hands_frame, off.sides[s].hands_frame)
