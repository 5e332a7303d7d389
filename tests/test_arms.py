"""One pass 1 for both arms (align.passes.Arm, stages.align.arms_together): worked answers on
small known warps, and the bundled sample."""

from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from splicer import splice
from splicer.align.costs import d1_cost, phase_features
from splicer.align.passes import Arm, arm_paths, pass1, path_median, warp_markers
from splicer.options import SpliceOptions
from splicer.stages.align import arms_together

from test_align import _arm, _warped

MOTIONS = Path(__file__).resolve().parents[1] / "motions"


def _same_warp(seed, n=90, m=110):
    """Another arm (motion ``seed``) under :func:`test_align._warped`'s warp."""
    body = _arm(n, seed=seed)
    w = (n - 1) * (np.arange(m) / (m - 1)) ** 1.2
    return body, warp_markers(body, w)


def test_two_equal_arms_are_the_one_arm_pass():
    body, hands, _ = _warped()
    one = pass1(body, hands, width=20.0)
    two = pass1(body, hands, width=20.0, others=[Arm(body, hands)])
    np.testing.assert_array_equal(two.path, one.path)
    np.testing.assert_array_equal(two.local_cost(two.band, 0, 90), one.local_cost(one.band, 0, 90))
    assert (one.arms, two.arms, one.arm_costs) == (1, 2, ())
    own = arm_paths(two)
    assert len(own) == 2 and arm_paths(one) == []
    for path in own:  # each arm's own path in the same band is the one-arm pass's path
        np.testing.assert_array_equal(path, one.path)


def test_the_local_cost_is_the_mean_of_the_arms():
    body, hands, _ = _warped()
    b2, h2 = _same_warp(1)
    pr = pass1(body, hands, width=20.0, smooth_s=0.05, others=[Arm(b2, h2, smooth_s=0.1)])
    want = [d1_cost(phase_features(b, smooth_s=s), phase_features(h, smooth_s=s))(pr.band, 0, 90)
            for b, h, s in ((body, hands, 0.05), (b2, h2, 0.1))]  # each arm with its own smoothing
    np.testing.assert_allclose(pr.local_cost(pr.band, 0, 90), (want[0] + want[1]) / 2)
    np.testing.assert_allclose(pr.arm_costs[1](pr.band, 0, 90), want[1])


def test_an_arm_that_says_little_is_carried_by_the_other():
    """The first arm's hands markers show another motion (a gesture performed differently):
    alone its path is 4.8 hands frames off on average; with a second arm that shows the same
    performance, 0.51 (measured; the second arm alone: 0.34)."""
    body, _, truth = _warped()
    wrong = _same_warp(7)[1]
    b2, h2 = _same_warp(1)
    alone = np.abs(path_median(pass1(body, wrong, width=20.0).path, 90) - truth).mean()
    joint = pass1(body, wrong, width=20.0, others=[Arm(b2, h2)])
    together = np.abs(path_median(joint.path, 90) - truth).mean()
    assert alone > 4.0 and together < 0.6
    own = [np.abs(path_median(path, 90) - truth).mean() for path in arm_paths(joint)]
    assert own[0] == pytest.approx(alone) and own[1] < 0.4  # the cross-check sees the arms part


def test_open_ended_arms():
    """Open ends: the hands take runs 20 frames past the body's span; both arms give the same
    uncovered penalty and the same corners as one."""
    body, hands, _ = _warped()
    longer = warp_markers(hands, np.concatenate([np.arange(110.0), np.full(20, 109.0)]))
    one = pass1(body, longer, width=20.0, ends="open", coarse_fps=body.fps)
    two = pass1(body, longer, width=20.0, ends="open", coarse_fps=body.fps, others=[Arm(body, longer)])
    np.testing.assert_array_equal(two.path, one.path)
    assert two.uncovered_cost == pytest.approx(one.uncovered_cost) and two.covered == one.covered
    for path in arm_paths(two):
        np.testing.assert_array_equal(path, one.path)


def test_arms_share_their_takes_frames():
    body, hands, _ = _warped()
    with pytest.raises(ValueError, match="share their takes' frames"):
        pass1(body, hands, width=20.0, others=[Arm(_arm(80), hands)])
    with pytest.raises(TypeError, match="Arm"):
        pass1(body, hands, width=20.0, others=[(body, hands)])


def _side(pins=(), n=10, m=20, fps=30.0):
    mk = SimpleNamespace(n_frames=n, fps=fps)
    return SimpleNamespace(body=mk, hands=SimpleNamespace(n_frames=m, fps=fps), pins=pins)


def test_when_both_arms_go_together():
    both, each = SpliceOptions(), SpliceOptions(pass1_arms="each")
    pair = {"left": _side(), "right": _side()}
    assert arms_together(pair, both) and not arms_together(pair, each)
    assert not arms_together({"left": _side()}, both)                       # one side
    assert not arms_together({"left": _side(pins=(1,)), "right": _side()}, both)  # a pin for one side only
    assert not arms_together({"left": _side(m=21), "right": _side()}, both)  # not one pair of takes
    assert not arms_together(pair, SpliceOptions(passes="pass2"))          # no pass 1


@pytest.fixture(scope="module")
def sample():
    return splice(MOTIONS / "sample_body.bvh", MOTIONS / "sample_hands.bvh", config=MOTIONS / "sample_sync.yaml")


def test_the_sample_aligns_both_arms_at_once(sample):
    left, right = sample.sides["left"], sample.sides["right"]
    assert left.pass1 is right.pass1 and left.pass1.arms == 2  # computed once, for both
    assert left.pass2 is not right.pass2                          # pass 2 stays per side
    rep = sample.report.to_dict()
    assert {s: d["pass1"]["arms"] for s, d in rep["sides"].items()} == {"left": 2, "right": 2}
    assert rep["options"]["pass1_arms"] == "both"
    for r in (left, right):  # each arm's own path, for the cross-check
        assert r.alignment.own is not None and r.alignment.own.shape == r.hands_frame.shape
    apart = splice(MOTIONS / "sample_body.bvh", MOTIONS / "sample_hands.bvh", config=MOTIONS / "sample_sync.yaml",
                   pass1_arms="each")
    assert apart.sides["left"].pass1.arms == 1 and apart.sides["left"].pass1 is not apart.sides["right"].pass1
    assert apart.sides["left"].alignment.own is None


def test_the_plot_samples_a_shared_pass_once(sample, tmp_path, monkeypatch):
    import splicer.plot as P

    calls = []
    real = P.band_image
    monkeypatch.setattr(P, "band_image", lambda pr, **kw: calls.append(pr.name) or real(pr, **kw))
    P.plot_alignment(sample, tmp_path / "a.png")
    assert sorted(calls) == ["pass1", "pass2", "pass2"] and (tmp_path / "a.png").stat().st_size > 0


def test_an_arm_aligned_as_if_alone():
    """arm_alone: an arm's own locating pass, own penalty and own band, as pass 1 would have run
    for it alone (the ends check of stages.align._arm_together).  Two equal arms: each arm alone
    is the one-arm pass, at a locating rate of 10 fps (3 body frames per coarse frame)."""
    from splicer.align.passes import arm_alone

    body, hands, _ = _warped()
    longer = warp_markers(hands, np.concatenate([np.arange(110.0), np.full(20, 109.0)]))
    one = pass1(body, longer, width=20.0, ends="open", coarse_fps=10.0)
    two = pass1(body, longer, width=20.0, ends="open", coarse_fps=10.0, others=[Arm(body, longer)])
    assert two.located.arm_uncovered == (one.uncovered_cost, one.uncovered_cost)
    for k in (0, 1):
        np.testing.assert_array_equal(arm_alone(two, k), one.path)
    with pytest.raises(ValueError, match="open-ended pass 1 over several arms"):
        arm_alone(one, 0)


def test_the_cli_option(tmp_path, capsys):
    import json

    from splicer.cli import main

    for arms, want in (("each", 1), ("both", 2)):
        rep = tmp_path / f"{arms}.json"
        code = main([str(MOTIONS / "sample_body.bvh"), str(MOTIONS / "sample_hands.bvh"),
                     "-o", str(tmp_path / f"{arms}.bvh"), "--report", str(rep), "--pass1-arms", arms, "-q"])
        d = json.loads(rep.read_text())
        assert code == 0 and d["options"]["pass1_arms"] == arms
        assert {s: x["pass1"]["arms"] for s, x in d["sides"].items()} == {"left": want, "right": want}
    with pytest.raises(SystemExit) as e:  # argparse: a usage error
        main([str(MOTIONS / "sample_body.bvh"), str(MOTIONS / "sample_hands.bvh"), "-o", str(tmp_path / "x.bvh"),
              "--pass1-arms", "three"])
    assert e.value.code == 2 and "invalid choice" in capsys.readouterr().err
    assert not (tmp_path / "x.bvh").exists()


# ---------------------------------------------------------------------------------------
# an arm's corner-to-corner path against the other arm (stages.align._contradicted)
# ---------------------------------------------------------------------------------------
def _fake_pass(covered, other_cost, u=(1.0, 1.0)):
    """A two-arm pass over a 10 x 10 matrix: arm 0 costs 0 everywhere, arm 1 ``other_cost(i, j)``."""
    from splicer.align.band import full_band

    full = [np.zeros((10, 10)), np.fromfunction(np.vectorize(other_cost), (10, 10))]

    def cost_of(k):
        def cost(band, i0, i1):
            w = band.max_row_width
            padded = np.pad(full[k], ((0, 0), (0, w)))
            return np.array([padded[i, band.lo[i]:band.lo[i] + w] for i in range(i0, i1)])
        return cost

    return SimpleNamespace(covered=covered, arm_costs=(cost_of(0), cost_of(1)), arm_uncovered=u,
                           uncovered_cost=1.0, band=full_band(10, 10))


def test_a_corner_path_the_other_arm_contradicts_is_not_trusted():
    """Worked answers at 1 fps (the 1-s minimum is one body frame): the diagonal runs corner to
    corner; the shared path left body frames 7-9 uncovered.  The other arm's cost along the
    diagonal there: 2 (twice its penalty): contradicted; 0.5: trusted; with nothing left
    uncovered there is nothing to check."""
    from splicer.stages.align import _contradicted

    q = np.stack([np.arange(10), np.arange(10)], axis=1)
    sides = ["left", "right"]
    high = _fake_pass((0, 6), lambda i, j: 2.0 if i >= 7 else 0.0)
    why = _contradicted(high, 0, q, sides, 10, 10, 1.0)
    assert why is not None and "body frames 7-9" in why and "right arm" in why and "2.0x" in why
    assert _contradicted(_fake_pass((0, 6), lambda i, j: 0.5), 0, q, sides, 10, 10, 1.0) is None
    assert _contradicted(_fake_pass((0, 9), lambda i, j: 9.0), 0, q, sides, 10, 10, 1.0) is None
    # fewer uncovered rows than the 1-s minimum (at 5 fps: 5 rows): not checked
    assert _contradicted(high, 0, q, sides, 10, 10, 5.0) is None
    # the other arm's own penalty decides, not the shared one
    assert _contradicted(_fake_pass((0, 6), lambda i, j: 2.0 if i >= 7 else 0.0, u=(1.0, 3.0)), 0, q, sides, 10,
                         10, 1.0) is None


def test_costs_along_a_path_outside_the_pass_band():
    """costs_along against a loop over the path's cells, on a real two-arm pass and a path that
    leaves its band (an arm's own path in the ends check need not lie in the shared band)."""
    from splicer.align.evidence import costs_along

    body, hands = _same_warp(3)
    other_b, other_h = _same_warp(4)
    p = pass1(body, hands, width=8.0, others=[Arm(other_b, other_h)])
    n, m = body.n_frames, hands.n_frames
    q = np.stack([np.arange(n), np.round(np.linspace(0, m - 1, n)).astype(np.int64)], axis=1)  # the plain diagonal
    steps = np.diff(q, axis=0)
    fill = [q[0]]
    for (i, j), (di, dj) in zip(q[:-1], steps):  # make it a connected path
        for t in range(1, dj):
            fill.append([i, j + t])
        fill.append([i + di, j + dj])
    q = np.array(fill)
    from splicer.align.band import full_band

    whole = full_band(n, m)
    for k in (0, 1):
        dense = np.asarray(p.arm_costs[k](whole, 0, n))
        expect = np.full(n, np.nan)
        for i in range(n):
            js = q[q[:, 0] == i, 1]
            expect[i] = np.mean(dense[i, js - whole.lo[i]])
        np.testing.assert_allclose(costs_along(p.arm_costs[k], q, n, m), expect, rtol=1e-12)


@pytest.mark.slow
def test_an_arm_alone_does_not_stretch_a_partial_hands_take_over_the_body(monkeypatch):
    """Synthetic *all*, tuning seed 5: the hands take covers 76 % of the body.  The left arm
    aligned alone runs corner to corner; before, that made the pair end to end and gave every
    uncovered body frame hands material (0.163 s mean error).  The right arm matches that path
    no better than unrelated material where the shared open ends leave the body uncovered, so
    the open ends are kept: the end the shared path leaves is reported uncovered (about a
    quarter of the truly uncovered frames; the rest lie where the shared path starts at the
    body's first frame) and every covered frame keeps hands material.  The second opinion on
    the position weight (splicer.stages.recheck) is off here: it keeps this pair's alignment at
    weight 30 (measured: the same mean errors, 0.076 / 0.067 s), where no arm alone runs corner
    to corner.  Open ends on one take's first and last frames (``both_skip="off"``): skipping
    both takes' tails, the shared path here runs to the body's last frame, leaving nothing
    uncovered for the other arm to contradict, and the pair goes end to end (0.33.0, measured:
    0.031 / 0.025 s mean error, no frame reported uncovered; benchmarks/HISTORY.md)."""
    import splicer.defaults as D
    from splicer.evaluation.scenarios import alignment_error_s, make_scenario, scenario
    from splicer.evaluation.synth import make_gesture_take

    monkeypatch.setattr(D, "POSITION_WEIGHT_RECHECK", 0.0)
    take = make_gesture_take(60.0, 30.0, np.random.default_rng(0))
    sep = make_scenario(take, scenario("all"), rng=np.random.default_rng(5))
    res = splice(sep.body, sep.hands, both_skip="off")
    warnings = " | ".join(res.report["warnings"])
    assert "the open ends are kept" in warnings and "aligned end to end" not in warnings
    truly = ~np.asarray(sep.covered)
    for s, sd in res.sides.items():
        hf = np.asarray(sd.hands_frame, dtype=np.float64)
        assert sd.alignment.ends == "open"
        assert np.isnan(hf[truly]).mean() > 0.25  # measured 0.28 (313 of 433 still get material)
        assert np.isfinite(hf[~truly]).all()
        assert np.nanmean(alignment_error_s(sep, hf)) < 0.13  # measured 0.103 s
