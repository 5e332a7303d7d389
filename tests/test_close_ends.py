"""Open ends that stop short of real material (0.20.0): an open-ended path's end re-aligned with the
end fixed at the hands take's corner (:func:`splicer.align.openend.close_end`), checked against a
plain DTW over the block, on material that continues the performance and on unrelated material;
and the stage rule that turns such a pair end to end (:func:`splicer.stages.align._close_ends`)."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from splicer import defaults as D
from splicer.align.openend import EndClosure, close_end
from splicer.align.passes import pass1, warp_markers
from splicer.stages.align import _close_ends

from test_dtw import as_callable
from test_openend import _cat, _cut, ref_open_dtw, sample_markers  # noqa: F401  (fixture)


def _matrix_cost(C):
    """A pass's ``local_cost`` ``(band, i0, i1)`` over a full cost matrix."""
    return lambda band, i0, i1: as_callable(C, band)(i0, i1)


@pytest.mark.parametrize("end", ["head", "tail"])
def test_close_end_is_a_plain_dtw_over_the_block(end):
    rng = np.random.default_rng(7)
    n, m = 30, 45
    C = rng.uniform(0.0, 1.0, size=(n, m))
    # an open path that covers every body frame but leaves 6 hands frames at the head and 8 at the tail
    js = np.round(np.linspace(6, m - 9, n)).astype(int)
    path = np.stack([np.arange(n), js], axis=1)
    c = close_end(path, _matrix_cost(C), n, m, end, rows=10)
    if end == "tail":
        r0, c0 = path[n - 1 - 10]
        block = C[r0:, c0:]
        part = path[n - 1 - 10:]
        assert c.left_hands == 8 and tuple(c.path[0]) == (r0, c0) and tuple(c.path[-1]) == (n - 1, m - 1)
    else:
        r1, c1 = path[10]
        block = C[:r1 + 1, :c1 + 1]
        r0 = c0 = 0
        part = path[:11]
        assert c.left_hands == 6 and tuple(c.path[0]) == (0, 0) and tuple(c.path[-1]) == (r1, c1)
    cost, ref_path = ref_open_dtw(block, np.ones(block.shape, bool), False, False, 0.0)[:2]
    np.testing.assert_array_equal(c.path - [r0, c0], ref_path)
    assert c.closed_cost == pytest.approx(cost / len(ref_path))
    assert c.open_cost == pytest.approx(np.mean([C[i, j] for i, j in part]))


def test_excess_worked_answers():
    c = EndClosure("tail", np.zeros((1, 2), np.int64), open_cost=2.0, closed_cost=3.0, left_hands=5)
    assert c.excess(6.0) == pytest.approx(0.25)     # a quarter of the way from 2 to unrelated material's 6
    assert c.excess(2.0) == np.inf                  # the open path already costs as much: no answer
    assert EndClosure("head", c.path, 2.0, 1.5, 5).excess(4.0) == pytest.approx(-0.25)
    with pytest.raises(ValueError, match="head"):
        close_end(np.zeros((2, 2), np.int64), None, 2, 2, "middle", 1)


def _slow_tail(body, slow_s=3.0, factor=3.0):
    """Hands frames of a take that shows ``body`` in time, then its last ``slow_s`` seconds
    ``factor`` times slower: the body frame each hands frame shows."""
    n, fps = body.n_frames, body.fps
    k = int(slow_s * fps)
    head = np.arange(n - k, dtype=float)
    tail = np.linspace(n - k, n - 1, int(k * factor))
    return np.concatenate([head, tail])


@pytest.fixture
def slow_tail(sample_markers):
    """Hands = the body with its last 3 s three times slower; an open path along the truth that
    stops 5 s of hands material short of the corner (what the free open end does with a slower
    tail); the same take followed by 5 s of the other arm's motion instead; pass 1 over each."""
    full, other = sample_markers
    body = _cut(full, 140, 556)
    n, fps = body.n_frames, body.fps
    shows = _slow_tail(body)
    hands = warp_markers(body, shows)
    m = hands.n_frames
    truth = np.interp(np.arange(n), shows, np.arange(m))        # hands frame of each body frame
    short = int(5 * fps)                                          # the open path stops here
    keep = truth < m - 1 - short
    path = np.stack([np.arange(n)[keep], np.round(truth[keep]).astype(int)], axis=1)
    path = np.concatenate([path, [[n - 1, path[-1, 1] + 1]]])     # the last body frame on the next hands frame
    unrelated = _cat([_cut(hands, 0, int(path[-1, 1]) + 1), _cut(other, 0, short)])
    return SimpleNamespace(n=n, m=m, fps=fps, truth=truth, short=short, path=path, mu=unrelated.n_frames,
                           p=pass1(body, hands, width=30.0, ends="open"),
                           pu=pass1(body, unrelated, width=30.0, ends="open"))


def test_a_slower_tail_is_material_that_continues_the_performance(slow_tail):
    """The slower tail closes at a small cost, along the truth; the other arm's motion costs like
    unrelated material."""
    t = slow_tail
    rows = int(D.CLOSE_ENDS_S * t.fps)
    c = close_end(t.path, t.p.local_cost, t.n, t.m, "tail", rows)
    assert c.left_hands >= t.short
    assert c.excess(t.p.uncovered_cost) < 0.2
    body_rows = np.unique(c.path[:, 0])
    mid = np.array([c.path[c.path[:, 0] == i, 1].mean() for i in body_rows])  # several hands frames a row
    err = np.abs(mid - t.truth[body_rows])
    assert np.median(err) < 3.0 and tuple(c.path[-1]) == (t.n - 1, t.m - 1)  # 3 hands frames: one body frame here
    cu = close_end(t.path, t.pu.local_cost, t.n, t.mu, "tail", rows)
    assert cu.excess(t.pu.uncovered_cost) > 2 * D.CLOSE_ENDS_EXCESS


def test_the_stage_closes_only_ends_whose_material_continues(slow_tail):
    t = slow_tail
    fake = SimpleNamespace(path=t.path, local_cost=t.p.local_cost, uncovered_cost=t.p.uncovered_cost)
    guide, note = _close_ends(fake, t.n, t.m, t.fps)
    assert tuple(guide[0]) == (0, 0) and tuple(guide[-1]) == (t.n - 1, t.m - 1)
    assert np.all(np.diff(guide, axis=0) >= 0) and np.all(np.abs(np.diff(guide, axis=0)).sum(axis=1) >= 1)
    assert "at the end" in note and "--ends open" in note
    # body frames left uncovered: the hands take is shorter, not slower; nothing to close
    fake_short = SimpleNamespace(path=t.path[t.path[:, 0] < t.n - 2 * t.fps], local_cost=t.p.local_cost,
                                 uncovered_cost=t.p.uncovered_cost)
    assert _close_ends(fake_short, t.n, t.m, t.fps) == (None, None)
    # unrelated material past the end: left open
    fake = SimpleNamespace(path=t.path, local_cost=t.pu.local_cost, uncovered_cost=t.pu.uncovered_cost)
    assert _close_ends(fake, t.n, t.mu, t.fps) == (None, None)
    # more material than CLOSE_ENDS_MAX_S past the path's end: not a slower end but extra material, left
    # open before anything is aligned (the costs are never asked for columns past the real take's)
    def never(*a):
        raise AssertionError("costs asked for")

    fake = SimpleNamespace(path=t.path, local_cost=never, uncovered_cost=t.p.uncovered_cost)
    assert _close_ends(fake, t.n, int(t.path[-1, 1]) + 1 + int(D.CLOSE_ENDS_MAX_S * t.fps) + 10, t.fps) == (None, None)


def test_pins_the_closed_path_must_pass(slow_tail):
    """With pins: closed when the closed path passes every pin's window; left open when a pin in the
    re-aligned block lies off it, and when fixed ends contradict a pin (constraints None)."""
    from splicer.align.band import Constraint
    from splicer.align.frames import Pin

    t = slow_tail
    fake = SimpleNamespace(path=t.path, local_cost=t.p.local_cost, uncovered_cost=t.p.uncovered_cost)
    free, _ = _close_ends(fake, t.n, t.m, t.fps)
    mid = t.n // 2
    true_pin = Constraint(mid, int(round(t.truth[mid])), 2)
    guide, note = _close_ends(fake, t.n, t.m, t.fps, (true_pin,))
    assert guide is not None and np.array_equal(guide, free) and "at the end" in note
    # a pin inside the re-aligned block (the body's last 2 s), 40 hands frames off the closed path
    x = t.n - 10
    y = int(free[free[:, 0] == x, 1].min()) - 40
    pins = (Pin(mid, true_pin.y, 2, "sync.yaml, line 2: pair 1"), Pin(x, y, 2, "sync.yaml, line 3: pair 2"))
    guide, note = _close_ends(fake, t.n, t.m, t.fps, (true_pin, Constraint(x, y, 2)), pins)
    assert guide is None and "at the end" in note and "would miss sync.yaml, line 3: pair 2" in note
    assert "the ends stay open" in note
    assert _close_ends(fake, t.n, t.m, t.fps, None, pins) == (None, None)


def test_missed_constraint_worked_answers():
    from splicer.align.band import Constraint
    from splicer.stages.align import _missed_constraint

    path = np.array([[0, 0], [1, 1], [1, 2], [2, 5]])
    assert _missed_constraint(path, ()) is None
    assert _missed_constraint(path, (Constraint(1, 3, 1),)) is None          # column 2 is within 1 of 3
    assert _missed_constraint(path, (Constraint(1, 4, 1),)) == Constraint(1, 4, 1)  # columns 1-2 are not within 1 of 4
    assert _missed_constraint(path, (Constraint(0, 0, 0), Constraint(2, 3, 1))) == Constraint(2, 3, 1)  # row 2 is on 5
    assert _missed_constraint(path, (Constraint(2, 3, 2), Constraint(0, 0, 0))) is None


def test_a_head_of_more_than_ten_seconds_is_looked_at(sample_markers):
    """The hands performer six times slower over the body's first 3 s, and an open path along the
    truth that starts 11 s of hands material in (what the free open begin does with a slower head):
    more than 0.20.0's 10 s limit, which left such a head open without a look.  The stage closes
    it, along the truth; the same 11 s of the other arm's motion stays open."""
    full, other = sample_markers
    body = _cut(full, 140, 556)
    n, fps = body.n_frames, body.fps
    k = int(3 * fps)
    shows = np.concatenate([np.linspace(0, k, 6 * k, endpoint=False), np.arange(k, n, dtype=float)])
    hands = warp_markers(body, shows)
    m = hands.n_frames
    truth = np.interp(np.arange(n), shows, np.arange(m))          # hands frame of each body frame
    short = int(11 * fps)                                          # the open path starts here
    assert 10 * fps < short <= D.CLOSE_ENDS_MAX_S * fps
    keep = truth > short
    path = np.stack([np.arange(n)[keep], np.round(truth[keep]).astype(int)], axis=1)
    path = np.concatenate([[[0, path[0, 1] - 1]], path])           # the first body frame on the hands frame before
    p = pass1(body, hands, width=30.0, ends="open")
    guide, note = _close_ends(SimpleNamespace(path=path, local_cost=p.local_cost, uncovered_cost=p.uncovered_cost),
                              n, m, fps)
    assert guide is not None and tuple(guide[0]) == (0, 0) and tuple(guide[-1]) == tuple(path[-1])
    assert np.all(np.diff(guide, axis=0) >= 0) and "at the start" in note
    closed = np.unique(guide[guide[:, 0] < path[1, 0], 0])       # several hands frames a row
    mid = np.array([guide[guide[:, 0] == i, 1].mean() for i in closed])
    assert np.median(np.abs(mid - truth[closed])) < 6.0            # 6 hands frames: one body frame here
    # 11 s of the other arm's motion before the same material: left open
    unrelated = _cat([_cut(other, 0, short + 1), _cut(hands, short + 1, m)])
    pu = pass1(body, unrelated, width=30.0, ends="open")
    fake = SimpleNamespace(path=path, local_cost=pu.local_cost, uncovered_cost=pu.uncovered_cost)
    assert _close_ends(fake, n, unrelated.n_frames, fps) == (None, None)


@pytest.fixture(scope="module")
def speed_imitation_seed1():
    """The synthetic *speed + imitation* pair of tuning seed 1, whose open end stopped 7.7 s of hands
    material short (0.19.0)."""
    from splicer.evaluation.scenarios import make_scenario, scenario
    from splicer.evaluation.synth import make_gesture_take

    take = make_gesture_take(60.0, 30.0, np.random.default_rng(0))
    return make_scenario(take, scenario("speed+imitation"), rng=np.random.default_rng(1))


def _spliced_end_to_end(sep, says, **kw):
    """Splice the scenario pair ``sep`` (``kw``: :func:`splicer.splice`'s); one warning holds every
    string of ``says`` and every side is aligned end to end.  Returns side -> (hands frames, error
    in seconds per body frame)."""
    from splicer import splice
    from splicer.evaluation.scenario_types import alignment_error_s

    r = splice(sep.body, sep.hands, **kw)
    assert any(all(x in w for x in says) for w in r.report["warnings"])
    out = {}
    for s, v in r.sides.items():
        assert r.report["sides"][s]["ends"] == "fixed"
        out[s] = (v.hands_frame, alignment_error_s(sep, v.hands_frame))
    return out


def test_a_splice_whose_hands_run_slower_at_the_end_is_aligned_end_to_end(speed_imitation_seed1):
    """The synthetic pair of tuning seed 1 (errors up to 1 s over the body's last 2 s, 0.19.0): now
    end to end, with a note, and the last 2 s within 0.1 s."""
    sep = speed_imitation_seed1
    k = int(2 * sep.body.fps)
    for _, e in _spliced_end_to_end(sep, ("left hands material that matches the performance",)).values():
        assert np.nanmean(e[-k:]) < 0.1                         # 0.19.0: 0.57 and 0.66 s


def test_a_splice_whose_hands_run_a_third_as_fast_at_the_start_is_aligned_end_to_end(shared_motions):
    """The ZEGGS *speed + imitation* pair of tuning seed 4: the hands performer 0.34x as fast as the
    body over its first 4.3 s, so the free open begin started 10.1 s of hands material in, just
    over 0.20.0's 10 s limit (errors 0.11 s on average, 3.4 s at the start).  Now end to end,
    with a note, within 0.1 s at the start and 0.05 s on average."""
    from splicer.evaluation.scenarios import make_scenario, scenario
    from splicer.io.bvh import read_bvh

    take = read_bvh(shared_motions / "zeggs" / "067_Speech_2_x_1_0.bvh")
    sep = make_scenario(take, scenario("speed+imitation"), rng=np.random.default_rng(4))
    k = int(4 * sep.body.fps)
    for _, e in _spliced_end_to_end(sep, ("s at the start", "matches the performance")).values():
        assert np.nanmax(e[:k]) < 0.1 and np.nanmean(e) < 0.05      # 0.20.0: 3.4 s and 0.11 s


def test_a_pinned_splice_whose_hands_run_slower_at_the_end_is_aligned_end_to_end(speed_imitation_seed1):
    """The synthetic pair of tuning seed 1 (above) with two true pins mid-take (tolerance 2): before
    0.23.0 a pinned pair kept its open ends and its last 2 s were 0.5-0.7 s off; now closed as
    without pins, and the pins hold."""
    from splicer.io.config import parse_config

    sep = speed_imitation_seed1
    n = sep.body.n_frames
    xs = [n // 3, n // 2]
    ys = [int(round(sep.truth[x])) for x in xs]
    text = "pairs:\n" + "".join(f"  - {{body: {x}, hands: {y}}}\n" for x, y in zip(xs, ys)) + "tolerance: 2\n"
    k = int(2 * sep.body.fps)
    sides = _spliced_end_to_end(sep, ("left hands material that matches the performance",),
                                config=parse_config(text, "pins.yaml"))
    for hf, e in sides.values():
        for x, y in zip(xs, ys):
            assert abs(hf[x] - y) <= 2 + 1e-9
        assert np.nanmean(e[-k:]) < 0.1
