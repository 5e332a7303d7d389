"""Worked answers for splicer.align.band: band geometry by hand, the band-width policy and the
Band record (ALGORITHM.md sections 2-3; test_dtw.py checks the band against the DTW)."""

import math

import numpy as np
import pytest

from splicer.align.band import Band, Constraint, band_frames, make_band
from splicer.errors import BandError, ConstraintError


def test_diagonal_band_by_hand():
    # n = m = 5, W = 2: centre c(i) = i, Delta = 2 sqrt(4^2 + 4^2) / (2 * 4) = sqrt 2 = 1.414;
    # lo = ceil(i - 1.414) clipped at 0 = 0 0 1 2 3; hi = floor(i + 1.414) clipped at 4 = 1 2 3 4 4
    b = make_band(5, 5, 2.0)
    assert b.lo.tolist() == [0, 0, 1, 2, 3] and b.hi.tolist() == [1, 2, 3, 4, 4]
    assert b.n_cells == 2 + 3 + 3 + 3 + 2 and b.max_row_width == 3
    assert b.width == 2.0 and b.constraints == ()


def test_band_through_a_constraint_by_hand():
    # n = m = 5, W = 2, pin (2, 3, T = 0).
    # segment 1, (0, 0) -> (2, 3): Delta = 2 sqrt(13) / 4 = 1.803, c = 0, 1.5, 3:
    #   lo = ceil(c - 1.803) v 0 = 0 0 2 -> row 2 clipped to y - T = 3; hi = floor(c + 1.803) ^ 3 = 1 3 3
    # segment 2, (2, 3) -> (4, 4): Delta = 2 sqrt(5) / 4 = 1.118, rows 3, 4: c = 3.5, 4:
    #   lo = ceil(c - 1.118) v (3 - 0) = 3 3; hi = floor(c + 1.118) ^ 4 = 4 4
    b = make_band(5, 5, 2.0, [(2, 3)])
    assert b.lo.tolist() == [0, 0, 3, 3, 3] and b.hi.tolist() == [1, 3, 3, 4, 4]
    assert b.constraints == (Constraint(2, 3, 0),)
    assert b.contains(2, 3) and not b.contains(2, 2) and not b.contains(2, 4) and not b.contains(5, 3)
    assert b.contains(0, 0) and b.contains(0, 1) and not b.contains(0, 2) and not b.contains(-1, 0)


def test_tolerance_widens_the_constraint_row():
    # the same pin with T = 1: segment 1 is capped at y + T = 4: hi = floor(c + 1.803) ^ 4 = 1 3 4,
    # row 2 is clipped to [max(2, 3 - 1), 4] = [2, 4]; segment 2 starts at y - T = 2:
    # lo = max(2, ceil(3.5 - 1.118) = 3) = 3 and max(2, ceil(4 - 1.118) = 3) = 3, hi = 4 4
    b = make_band(5, 5, 2.0, [Constraint(2, 3, 1)])
    assert b.lo.tolist() == [0, 0, 2, 3, 3] and b.hi.tolist() == [1, 3, 4, 4, 4]


def test_one_row_band_is_the_whole_row():
    b = make_band(1, 7, 1.0)
    assert b.lo.tolist() == [0] and b.hi.tolist() == [6]


def test_too_narrow_band_names_the_smallest_width():
    # n = 3, m = 9: centre c = 0, 4, 8, Delta = W sqrt(2^2 + 8^2) / 4 = 2.061553 W.
    # lo[1] = ceil(4 - Delta) must be <= hi[0] + 1 = floor(Delta) + 1: true from Delta = 2
    # (2 <= 3), false just below (3 <= 2).  So W_min = 2 / 2.061553 = 0.970143, printed
    # rounded up to 0.971.
    with pytest.raises(BandError, match=r"W=0.5 frames cannot connect the segment between the start \(0, 0\) "
                                        r"and the end \(2, 8\) \(at body frame 1\); the smallest width that "
                                        r"connects the band is W=0.971 frames") as e:
        make_band(3, 9, 0.5)
    assert e.value.min_width == pytest.approx(0.970143, abs=1e-6)
    assert e.value.segment == 0
    make_band(3, 9, e.value.min_width)  # the width it names connects
    with pytest.raises(BandError):
        make_band(3, 9, 0.9701)


@pytest.mark.parametrize("args,match", [
    ((0, 5, 1.0), "n must be an integer >= 1"), ((5, 2.5, 1.0), "m must be an integer >= 1"),
    ((True, 5, 1.0), "n must be"), ((5, 5, "wide"), "number of frames"), ((5, 5, 0.0), "positive"),
    ((5, 5, math.inf), "positive"),
])
def test_make_band_refuses_bad_sizes_and_widths(args, match):
    with pytest.raises(BandError, match=match):
        make_band(*args)


@pytest.mark.parametrize("cons,match", [
    ([(2, 3, -1)], r"constraint #0 \(x=2, y=3\): tolerance T=-1 must be >= 0"),
    ([(0, 3)], r"body frame x must satisfy 0 < x < n-1 = 4"),
    ([(2, 4)], r"hands frame y must satisfy 0 < y < m-1 = 4"),
    ([(2, 2), (2, 3)], r"constraint #1 \(x=2, y=3\) does not follow constraint #0 \(x=2, y=2\)"),
    ([(2, 3), (3, 2)], r"constraint #1 \(x=3, y=2\) does not follow .* not decrease in y"),
    ([(2.5, 2)], r"x=2.5 must be an integer frame"),
    ([(2, 2.5)], r"^constraint #0: y=2.5 must be an integer frame$"),
    ([(2, 2, 0.5)], r"^constraint #0: tolerance=0.5 must be an integer frame$"),
    ([(2,)], r"constraint #0: expected \(x, y\[, T\]\)"),
    ([5], r"constraint #0: expected \(x, y\[, T\]\)"),
])
def test_constraint_messages_name_the_constraint(cons, match):
    with pytest.raises(ConstraintError, match=match):
        make_band(5, 5, 2.0, cons)


def test_band_record_validates_and_is_read_only():
    b = Band(3, 3, 1.0, [0, 0, 1], [1, 2, 2])
    assert repr(b) == "Band(n=3, m=3, width=1, cells=7, max_row_width=3, constraints=0)"
    with pytest.raises(ValueError):
        b.lo[0] = 1
    with pytest.raises(BandError, match="row 1: lo\\[i\\] > hi\\[i-1\\] \\+ 1"):
        Band(3, 4, 1.0, [0, 2, 3], [0, 2, 3])
    with pytest.raises(BandError, match="shape"):
        Band(3, 3, 1.0, [0, 0], [1, 2])


# -- band widths: numbers are frames, "30%" a share, "20s" seconds ----------------------------

@pytest.mark.parametrize("spec,n,fps,frames", [
    (1, 600, None, 1.0),          # one frame ...
    (1.0, 600, None, 1.0),
    (120, 600, None, 120.0),
    ("30%", 600, None, 180.0),    # 0.3 x 600
    ("99.9%", 600, None, 599.4),  # a share is written as one
    ("20s", 600, 60.0, 1200.0),   # 20 s x 60 fps
    ("1.5s", 600, 120.0, 180.0),
    ("2s", 600, 0.5, 1.0),          # a slow rate is a rate: 2 s at 0.5 fps is one frame
    ("7f", 600, None, 7.0),
])
def test_band_frames_policy(spec, n, fps, frames):
    assert band_frames(spec, n=n, fps=fps) == pytest.approx(frames, abs=1e-9)


def test_no_cliff_at_one_frame():
    # before: 0.999 was a share (599 frames of 600) while 1 was one frame
    assert band_frames(1, n=600) == 1.0
    with pytest.raises(ConstraintError, match=r"0.999 is less than one frame.*'99.9%'"):
        band_frames(0.999, n=600)


@pytest.mark.parametrize("fps", [0.0, -30.0, math.nan, math.inf])
def test_seconds_need_a_real_frame_rate(fps):
    with pytest.raises(ConstraintError, match="fps must be positive and finite"):
        band_frames("2s", n=100, fps=fps)


@pytest.mark.parametrize("n,m,lo,hi,message", [
    (2, 4, [2, 3], [3, 3], "invalid band at row 0: lo[0] must be 0, got 2"),
    (2, 3, [0, 1], [0, 1], "invalid band at row 1: hi[1] must be m - 1 = 2, got 1"),
    (4, 4, [0, 0, 0, 0], [2, 3, 2, 3], "invalid band at row 2: hi decreases"),
    (2, 3, [0, 2], [0, 2], "invalid band at row 1: lo[i] > hi[i-1] + 1 (rows do not connect)"),
    (3, 3, [0, -1, 0], [0, 1, 2], "invalid band at row 1: lo < 0"),
    (3, 3, [0, 1, 1], [1, 3, 2], "invalid band at row 1: hi > m - 1"),
    (3, 4, [0, 2, 2], [1, 1, 3], "invalid band at row 1: lo > hi"),
    (3, 4, [0, 2, 1], [2, 2, 3], "invalid band at row 2: lo decreases"),
    (3, 4, [0, 1, 1], [2, 1, 3], "invalid band at row 1: hi decreases"),
    (3, 6, [0, 3, 5], [1, 4, 5], "invalid band at row 1: lo[i] > hi[i-1] + 1 (rows do not connect)"),
    (1, 4, [0], [3], None),
    (2, 2, [0, 1], [0, 1], None),  # the diagonal: row 1 starts right after row 0 ends
])
def test_band_invariants_each_with_its_message(n, m, lo, hi, message):
    if message is None:
        b = Band(n, m, 1.0, lo, hi)
        assert b.lo.tolist() == lo and b.hi.tolist() == hi and b.n_cells == sum(h - l + 1 for l, h in zip(lo, hi))
        return
    with pytest.raises(BandError) as e:
        Band(n, m, 1.0, lo, hi)
    assert str(e.value) == message


def test_band_sizes_must_be_positive():
    with pytest.raises(BandError, match=r"band needs n >= 1 and m >= 1, got n=0, m=3"):
        Band(0, 3, 1.0, [], [])
    with pytest.raises(BandError, match=r"lo and hi must have shape \(2,\), got \(2,\) and \(1,\)"):
        Band(2, 3, 1.0, [0, 1], [2])


def test_infeasible_adjacent_pins_are_named():
    # pins on adjacent body frames must be reachable by one step: hands (y - T) - (y' + T') <= 1.
    # (2, 3 +- 1) -> (3, 5 +- 1): (5 - 1) - (3 + 1) = 0, fine; (3, 5 +- 1) -> (4, 12): 12 - 6 = 6
    with pytest.raises(ConstraintError) as e:
        make_band(20, 20, 5.0, [(2, 3, 1), (3, 5, 1), (4, 12, 0)])
    assert str(e.value) == ("constraints #1 (x=3, y=5, T=1) and #2 (x=4, y=12, T=0) are infeasible: adjacent "
                            "body frames cannot match hands frames more than T + T' + 1 apart")
    # a gap of exactly 1 is a step: (2, 3) -> (3, 5 +- 1): (5 - 1) - 3 = 1, fine; the culprit is the next pair
    with pytest.raises(ConstraintError, match=r"^constraints #1 \(x=3, y=5, T=1\) and #2"):
        make_band(20, 20, 5.0, [(2, 3, 0), (3, 5, 1), (4, 12, 0)])
    # a gap of exactly 2: (2, 3) -> (3, 5)
    with pytest.raises(ConstraintError, match=r"^constraints #0 \(x=2, y=3, T=0\) and #1 \(x=3, y=5, T=0\) are infeasible"):
        make_band(20, 20, 5.0, [(2, 3), (3, 5)])


def test_cells_exactly_on_the_border_are_inside():
    # n = m = 3, W = sqrt 2: Delta = sqrt(2) sqrt(8) / 4 = 1 (to rounding): the cells at
    # distance exactly 1 from the diagonal are in the band: lo = 0 0 1, hi = 1 2 2
    import math

    b = make_band(3, 3, math.sqrt(2))
    assert b.lo.tolist() == [0, 0, 1] and b.hi.tolist() == [1, 2, 2]


def test_band_record_normalises_its_fields_and_leaves_the_inputs_alone():
    lo, hi = np.array([0, 0, 1]), np.array([1.0, 2.0, 2.0])
    b = Band(np.int64(3), np.int64(3), 1, lo, hi, [Constraint(1, 1, 0)])
    assert type(b.n) is int and type(b.m) is int and type(b.width) is float
    assert b.constraints == (Constraint(1, 1, 0),) and isinstance(b.constraints, tuple)
    assert b.lo.dtype == np.int64 and b.hi.dtype == np.int64
    assert lo.flags.writeable and hi.flags.writeable  # copies were made read-only, not the inputs


def _random_path(rng, n, m):
    """A monotone path of unit steps from a random cell to a later one."""
    i, j = int(rng.integers(0, n)), int(rng.integers(0, m))
    cells = [(i, j)]
    while True:
        moves = [(di, dj) for di, dj in ((1, 0), (0, 1), (1, 1)) if i + di < n and j + dj < m]
        if not moves or rng.random() < 0.02:
            return np.array(cells)
        di, dj = moves[int(rng.integers(len(moves)))]
        i, j = i + di, j + dj
        cells.append((i, j))


def test_path_band_holds_exactly_the_path_in_its_rows():
    """path_band against a slow reference on 500 random monotone paths: in every row the path
    visits, the band's cells are that row's path cells (a connected run of columns); the other
    rows hold one cell at the path's first or last column; the band invariants hold."""
    from splicer.align.band import path_band

    rng = np.random.default_rng(7)
    for _ in range(500):
        n, m = int(rng.integers(1, 40)), int(rng.integers(1, 40))
        q = _random_path(rng, n, m)
        b = path_band(q, n, m)
        for i in range(n):
            js = q[q[:, 0] == i, 1]
            if len(js):
                assert (b.lo[i], b.hi[i]) == (js.min(), js.max())
                assert len(js) == js.max() - js.min() + 1
            elif i < q[0, 0]:
                assert b.lo[i] == b.hi[i] == q[0, 1]
            else:
                assert b.lo[i] == b.hi[i] == q[-1, 1]
        assert all(b.contains(int(i), int(j)) for i, j in q)
    with pytest.raises(BandError, match="leaves the 3 x 3 matrix"):
        path_band(np.array([[0, 0], [1, 3]]), 3, 3)
    with pytest.raises(BandError, match="non-empty"):
        path_band(np.zeros((0, 2), int), 3, 3)
