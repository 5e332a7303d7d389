"""Pins by pointing (splicer.review): the click handler, the local re-solve and the YAML, without a browser."""

from __future__ import annotations

from pathlib import Path

import matplotlib
import numpy as np
import pytest

from splicer.io.config import read_config
from splicer.review import PinReview

ROOT = Path(__file__).resolve().parents[1]
BODY, HANDS, SYNC = (ROOT / "motions" / n for n in ("sample_body.bvh", "sample_hands.bvh", "sample_sync.yaml"))
SYNC_PINS = [(90, 347), (240, 836), (390, 1245), (520, 1671)]


@pytest.fixture(scope="module")
def solved():
    return PinReview(BODY, HANDS, constraints=SYNC, side="left")


@pytest.fixture
def review(solved):
    """A fresh copy of the solved review (the solve is shared; pins and maps are the test's own)."""
    import copy

    r = copy.copy(solved)
    r.pins, r.per_frame, r.time_map, r.history = list(solved.pins), solved.per_frame.copy(), solved.time_map.copy(), []
    return r


def test_starts_from_the_constraints_file(review):
    assert [(p.body, p.hands) for p in review.pins] == SYNC_PINS
    for b, h in SYNC_PINS:  # the time map holds every pin within its tolerance (2 hands frames)
        assert abs(review.time_map[b] - h) <= 2 + 1e-9


def test_click_adds_a_pin_and_resolves_only_its_stretch(review):
    before, aligned = review.time_map.copy(), review.per_frame.copy()
    out = review.click(300.2, 999.6)
    assert out == {"action": "added", "pin": (300, 1000), "stretch": (240, 390)}
    assert [(p.body, p.hands) for p in review.pins] == SYNC_PINS[:2] + [(300, 1000)] + SYNC_PINS[2:]
    assert abs(review.time_map[300] - 1000) <= 2 + 1e-9
    # the alignment outside the stretch is kept exactly; the time map is rebuilt with the pins
    # held, which moves it up to the neighbouring pins (90 and 520) and no further
    outside = np.r_[0:240, 391:len(aligned)]
    np.testing.assert_array_equal(review.per_frame[outside], aligned[outside])
    far = np.r_[0:91, 521:len(before)]
    np.testing.assert_allclose(review.time_map[far], before[far], atol=1e-9)
    assert np.abs(review.time_map[280:320] - before[280:320]).max() > 1  # and the pin did move it
    assert np.all(np.diff(review.time_map) >= -1e-9)


def test_click_on_a_pin_removes_it(review):
    review.click(300, 1000)
    out = review.click(301, 1004)  # within 2% of each take of the pin
    assert out["action"] == "removed" and out["pin"] == (300, 1000) and out["stretch"] == (240, 390)
    assert [(p.body, p.hands) for p in review.pins] == SYNC_PINS


def test_a_click_that_breaks_the_order_is_refused(review):
    out = review.click(100, 200)  # after body 90/hands 347 but before it in the hands take
    assert out["action"] == "refused" and "increase in both takes" in out["why"]
    assert review.click(0, 5)["action"] == "refused"  # on the first frame: outside the pinnable range
    assert [(p.body, p.hands) for p in review.pins] == SYNC_PINS


def test_mouse_event_on_the_figure_is_a_click(review):
    from matplotlib.backend_bases import MouseEvent

    matplotlib.use("Agg")
    fig = review.figure(max_pixels=60)
    x, y = review._ax.transData.transform((450, 1400))
    out = review.on_click(MouseEvent("button_press_event", fig.canvas, x, y, button=1))
    assert out["action"] == "added" and out["pin"] == (450, 1400)
    xs, ys = review._dots.get_data()
    assert list(xs) == [90, 240, 390, 450, 520] and list(ys) == [347, 836, 1245, 1400, 1671]
    import matplotlib.pyplot as plt

    plt.close(fig)


def test_save_writes_the_pins_to_the_constraints_yaml(review, tmp_path):
    review.click(450, 1400)
    review.click(240, 836)  # remove a pair that applies to both sides: kept for the right side
    path = review.save(tmp_path / "sync.yaml")
    cfg = read_config(path)
    got = sorted((p.body, p.hands, p.side) for p in cfg.pairs)
    assert got == [(90, 347, "both"), (240, 836, "right"), (390, 1245, "both"), (450, 1400, "left"),
                   (520, 1671, "both")]
    assert cfg.tolerance == 2
