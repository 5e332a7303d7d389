"""The public API as a user imports it: through the package, with typed options, report and stages."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import splicer
from splicer.io.config import parse_config
from splicer.align.frames import FrameSpaces, Pin
from splicer.transfer.timemap import hold_pins

MOTIONS = Path(__file__).resolve().parents[1] / "motions"
BODY, HANDS = MOTIONS / "sample_body.bvh", MOTIONS / "sample_hands.bvh"


@pytest.fixture(scope="module")
def sample():
    return splicer.read_bvh(BODY), splicer.read_bvh(HANDS)


def test_every_public_name_resolves():
    for name in splicer.__all__:
        assert getattr(splicer, name) is not None, name
    assert set(splicer.__all__) <= set(dir(splicer))
    with pytest.raises(AttributeError, match="no attribute 'nope'"):
        splicer.nope  # noqa: B018


def test_import_forms_in_a_fresh_interpreter():
    code = ("import splicer; from splicer import splice, SpliceResult, SpliceOptions, Report; "
            "import splicer.pipeline; assert callable(splicer.splice) and splicer.splice is splice; "
            "assert splicer.SpliceResult.__name__ == 'SpliceResult'; print('ok')")
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                       cwd=Path(__file__).resolve().parents[1], timeout=120)
    assert p.returncode == 0, p.stderr
    assert p.stdout.strip() == "ok"


def test_help_reads_like_a_manual():
    doc = splicer.__doc__
    for word in ("read_bvh", "splice", "SpliceOptions", "Report", "align_side", "SplicerError"):
        assert word in doc


def test_splice_through_the_package_with_options_object(sample):
    body, hands = sample
    opts = splicer.SpliceOptions(side="left", band1=120)
    r = splicer.splice(body, hands, options=opts)
    r2 = splicer.splice(body, hands, side="left", band1=120)
    assert isinstance(r, splicer.SpliceResult) and isinstance(r.report, splicer.Report)
    np.testing.assert_array_equal(r.sides["left"].hands_frame, r2.sides["left"].hands_frame)
    # keyword overrides win over the options object
    r3 = splicer.splice(body, hands, options=opts, side="right")
    assert list(r3.sides) == ["right"]
    d = r.report.to_dict()
    assert json.loads(r.report.to_json()) == d
    assert d["sides"]["left"]["hands_frame"] == r.report["sides"]["left"]["hands_frame"]
    assert len(d["sides"]["left"]["hands_frame"]) == body.n_frames
    assert d["options"]["band1"] == 120 and d["options"]["side"] == "left"
    # short reprs, not a dump of arrays
    for obj in (r, r.report, r.sides["left"], r.report.sides["left"], opts):
        assert len(repr(obj)) < 300, type(obj).__name__
    assert repr(opts) == "SpliceOptions(side='left', band1=120)"


def test_stages_compose_like_splice(sample):
    body, hands = sample
    opts = splicer.SpliceOptions(side="right")
    inputs = splicer.load_inputs(body, hands)
    rig = splicer.find_rig(inputs, opts)
    assert rig.sides == ("right",)
    markers = splicer.side_markers(inputs, rig, "right")
    assert markers.body.n_frames == body.n_frames
    # the hands markers are at the body rate: 1985 frames at 60 fps -> 993 at 30 fps
    assert markers.hands.n_frames == (hands.n_frames - 1) // 2 + 1
    aln = splicer.align_side(markers, opts)
    tm = splicer.time_map(aln, markers, opts)
    sides = {"right": splicer.SideResult("right", tm, markers, aln)}
    sides = splicer.trend_time_maps(splicer.cross_check(sides), opts)
    weighed = sides["right"].hands_frame
    sides = splicer.refine_time_maps(sides, opts)
    refined = sides["right"].hands_frame
    sides = splicer.mark_coverage_edges(splicer.uncover_unsure_edges(splicer.estimate_risk(sides), opts))
    whole = splicer.splice(body, hands, options=opts)
    np.testing.assert_allclose(refined, whole.sides["right"].hands_frame)
    # the wrist's refinement moves the map by its radius at most each round (0.25 s = 15 hands frames;
    # defaults.WRIST_ROUNDS rounds; measured 16.2 with two)
    from splicer.defaults import WRIST_ROUNDS

    assert 0 < np.nanmax(np.abs(refined - weighed)) <= 15.0 * WRIST_ROUNDS
    assert np.all(np.diff(refined[np.isfinite(refined)]) >= 0)
    for k in ("est_error_s", "confidence"):
        np.testing.assert_allclose(getattr(sides["right"].alignment.confidence, k),
                                   getattr(whole.sides["right"].alignment.confidence, k))
    # the trend stage moved the map (it is not the identity here) and kept it monotone
    assert np.nanmax(np.abs(weighed - tm)) > 0.5
    assert np.all(np.diff(weighed[np.isfinite(weighed)]) >= 0)


def test_frame_spaces_worked_example():
    sp = FrameSpaces(n_body=601, n_hands=1985, body_fps=30.0, hands_fps=60.0)
    assert sp.ratio == 2.0
    assert sp.hands_to_common(300).item() == 150.0
    assert sp.common_to_hands(150.5).item() == 301.0
    assert sp.body_seconds(60).item() == 2.0
    # hands 301 -> common 150.5 rounds to 150 (banker's) with the rounding added to T:
    # T = ceil(2 / 2 + 0.5) = 2
    pins = (Pin(100, 300, 2, "a"), Pin(101, 301, 2, "b"))
    c = sp.dtw_constraints(pins, 993)
    assert [(k.x, k.y, k.tolerance) for k in c] == [(100, 150, 1), (101, 150, 2)]


def test_adjacent_pins_that_round_together_are_accepted(sample):
    """Issue 11: body 100/hands 300 and body 101/hands 301 were refused after re-rounding."""
    body, hands = sample
    cfg = parse_config("pairs:\n  - {body: 100, hands: 300}\n  - {body: 101, hands: 301}\ntolerance: 2\n", "sync.yaml")
    r = splicer.splice(body, hands, config=cfg, side="left")
    tm = r.sides["left"].hands_frame
    assert abs(tm[100] - 300) <= 2 and abs(tm[101] - 301) <= 2


def test_infeasible_pins_are_named_by_file_and_line(sample):
    body, hands = sample
    cfg = parse_config("pairs:\n  - {body: 100, hands: 300}\n  - {body: 101, hands: 400}\ntolerance: 0\n", "sync.yaml")
    with pytest.raises(splicer.ConstraintError) as e:
        splicer.splice(body, hands, config=cfg, side="left")
    msg = str(e.value)
    assert msg == ("left side: sync.yaml, line 3: pair 2 (body 101, hands 400, tolerance 0) cannot follow "
                   "sync.yaml, line 2: pair 1 (body 100, hands 300, tolerance 0): adjacent body frames cannot "
                   "match hands frames further apart than their tolerances allow")


def test_band_errors_are_translated_to_pins():
    from splicer.errors import BandError
    from splicer.pipeline import _pin_error

    e = BandError("a band of width W=3 frames cannot connect ... constraint #0 (x=5, y=9)")
    e.segment, e.min_width = 1, 41.2
    pins = (Pin(5, 18, 0, "s.yaml, line 2: pair 1", 2),)
    msg = str(_pin_error(e, pins, "right side"))
    assert msg == ("right side: the band cannot connect s.yaml, line 2: pair 1 (body 5, hands 18, tolerance 0) to "
                   "the end of both takes; a band of at least 41 body frames would (--band 42)")


@pytest.mark.parametrize("merge", ["timemap", "median"])
def test_pins_hold_with_every_merge(sample, merge):
    """Pins placed off the natural alignment still hold within T in the output time map."""
    body, hands = sample
    free = splicer.splice(body, hands, side="left", merge=merge).sides["left"].hands_frame
    xs = [150, 300, 450]
    ys = [int(round(free[x])) + d for x, d in zip(xs, (40, -40, 30))]
    text = "pairs:\n" + "".join(f"  - {{body: {x}, hands: {y}}}\n" for x, y in zip(xs, ys)) + "tolerance: 2\n"
    tm = splicer.splice(body, hands, side="left", merge=merge, config=parse_config(text, "s.yaml")).sides["left"].hands_frame
    for x, y in zip(xs, ys):
        assert abs(tm[x] - y) <= 2 + 1e-9, (x, y, tm[x])
    assert np.all(np.diff(tm) >= 0)


def test_hold_pins_worked_answers():
    tm = np.arange(10.0)
    # pin (4, 8, 1): row 4 must lie in [7, 9]; rows after it at least 7, rows before at most 9
    out = hold_pins(tm, [(4, 8.0, 1.0)], last=20)
    assert out.tolist() == [0, 1, 2, 3, 7, 7, 7, 7, 8, 9]
    # pin (6, 2, 0): row 6 exactly 2; everything before at most 2, after at least 2
    out = hold_pins(tm, [(6, 2.0, 0.0)], last=20)
    assert out.tolist() == [0, 1, 2, 2, 2, 2, 2, 7, 8, 9]
    # clipped to the take
    assert hold_pins(np.array([-1.0, 30.0]), [], last=20).tolist() == [0.0, 20.0]


@pytest.mark.parametrize("value", [-0.5, float("nan"), "heavy", True])
def test_position_weight_is_validated(value):
    from splicer.errors import SplicerError
    from splicer.options import resolve_options

    with pytest.raises(SplicerError, match="position_weight must be 'auto' or a number >= 0"):
        resolve_options(None, {"position_weight": value})
    assert resolve_options(None, {"position_weight": 0}).position_weight == 0
