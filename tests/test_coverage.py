"""Coverage edges: covered frames next to an uncovered range are low confidence (worked answers,
and a splice of the sample whose hands take covers only the middle half of the body)."""

from pathlib import Path

import numpy as np
import pytest

from splicer.align.confidence import Confidence
from splicer.defaults import COVERAGE_EDGE_S
from splicer.stages.coverage import coverage_edges

MOTIONS = Path(__file__).resolve().parents[1] / "motions"


def test_edges_each_side_of_every_uncovered_range():
    nan = np.nan
    # uncovered 0-1, 6, 11: two frames each side at 10 fps and 0.2 s
    hf = np.array([nan, nan, 2, 3, 4, 5, nan, 7, 8, 9, 10, nan, 12, 13, 14, 15, 16, 17])
    got = coverage_edges(hf, 10.0, 0.2)
    want = np.zeros(len(hf), dtype=bool)
    want[[2, 3, 4, 5, 7, 8, 9, 10, 12, 13]] = True
    np.testing.assert_array_equal(got, want)
    # rounding to whole frames: 0.14 s at 10 fps is 1 frame, 0.04 s none
    np.testing.assert_array_equal(np.flatnonzero(coverage_edges(hf, 10.0, 0.14)), [2, 5, 7, 10, 12])
    assert not coverage_edges(hf, 10.0, 0.04).any()
    # nothing uncovered, or nothing covered: no edges
    assert not coverage_edges(np.arange(8.0), 10.0, 0.5).any()
    assert not coverage_edges(np.full(8, nan), 10.0, 0.5).any()
    for bad in ((hf, 0.0, 0.2), (hf, 10.0, -1.0), (hf, np.inf, 0.2), (hf.reshape(2, -1), 10.0, 0.2)):
        with pytest.raises(ValueError):
            coverage_edges(*bad)


def test_with_floor_where_raises_only_the_masked_covered_frames():
    est = np.array([np.nan, 0.02, 0.5, 0.03, np.nan])
    c = Confidence(spread_frames=np.zeros(5), est_error_s=est, confidence=np.zeros(5), threshold=1.0,
                   error_scale_s=0.1)
    f = c.with_floor(0.25, where=np.array([True, True, True, False, False]))
    np.testing.assert_array_equal(f.est_error_s, [np.nan, 0.25, 0.5, 0.03, np.nan])  # uncovered stay NaN
    np.testing.assert_allclose(f.confidence, [0.0, 1 / (1 + 2.5 ** 2), 1 / (1 + 5.0 ** 2), 1 / (1 + 0.3 ** 2), 0.0])
    with pytest.raises(ValueError, match="boolean mask"):
        c.with_floor(0.25, where=np.ones(4, dtype=bool))
    with pytest.raises(ValueError, match="boolean mask"):
        c.with_floor(0.25, where=np.ones(5))


@pytest.mark.slow
def test_hands_covering_the_middle_half_flag_the_edges_of_their_coverage():
    """The sample's hands take cut to the stretch that shows body frames 150-450 (of 601): the
    body frames outside are uncovered, and the covered frames within COVERAGE_EDGE_S of them are
    low confidence whatever the alignment's own spread says; the time map is not changed."""
    from splicer import splice
    from splicer.io.bvh import read_bvh

    body, hands = read_bvh(MOTIONS / "sample_body.bvh"), read_bvh(MOTIONS / "sample_hands.bvh")
    truth = np.loadtxt(MOTIONS / "sample_truth.csv", delimiter=",", skiprows=1)[:, 1]
    j0, j1 = int(round(truth[150])), int(round(truth[450]))
    r = splice(body, hands.slice(j0, j1 + 1), side="left")
    s = r.report["sides"]["left"]
    unc = s["uncovered"]
    assert len(unc) == 2 and unc[0][0] == 0 and unc[1][1] == body.n_frames - 1
    a, b = unc[0][1] + 1, unc[1][0] - 1  # the covered stretch
    assert abs(a - 150) <= 15 and abs(b - 450) <= 15  # located to within half a second
    w = int(round(COVERAGE_EDGE_S * body.fps))
    est = np.array([np.nan if e is None else e for e in s["est_error_s"]])
    assert np.all(est[a:a + w] >= COVERAGE_EDGE_S - 1e-4) and np.all(est[b - w + 1:b + 1] >= COVERAGE_EDGE_S - 1e-4)
    low = np.zeros(body.n_frames, dtype=bool)
    for x, y in s["low_confidence"]:
        low[x:y + 1] = True
    assert low[a:a + w].all() and low[b - w + 1:b + 1].all()
    assert np.isnan(est[:a]).all() and np.isnan(est[b + 1:]).all()
    assert any("within 0.33 s of them count as low confidence" in n for n in r.report["warnings"])
    # the stage's edges on the final time map: exactly the w frames at each end of the covered stretch
    hf = np.asarray(r.sides["left"].hands_frame, dtype=np.float64)
    e = coverage_edges(hf, body.fps)
    assert e.sum() == 2 * w and e[a:a + w].all() and e[b - w + 1:b + 1].all()
