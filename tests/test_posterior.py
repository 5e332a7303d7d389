"""The pass-1 posterior: forward-backward sums against every path enumerated, and worked answers."""

import itertools

import numpy as np
import pytest

from splicer.align.band import Band
from splicer.align.dtw import dtw, make_band
from splicer.align.posterior import _rows_from_diagonals, path_posterior, tube_band


def _matrix_cost(C):
    """A band-chunk cost callable over a full matrix ``C`` (what d1_cost returns, for tests)."""

    def cost(band, i0, i1):
        out = np.full((i1 - i0, band.max_row_width), np.inf)
        for r, i in enumerate(range(i0, i1)):
            w = band.hi[i] - band.lo[i] + 1
            out[r, :w] = C[i, band.lo[i]:band.hi[i] + 1]
        return out

    return cost


def _paths(start, end, cells):
    """Every monotone path (steps (1,1), (1,0), (0,1)) from ``start`` to ``end`` through ``cells``."""
    out = []

    def walk(p):
        i, j = p[-1]
        if (i, j) == end:
            out.append(list(p))
            return
        for di, dj in ((1, 1), (1, 0), (0, 1)):
            q = (i + di, j + dj)
            if q in cells:
                walk(p + [q])

    walk([start])
    return out


def _reference(C, band, path, temperature, radius, pen, hw, held=None):
    """Row means and spreads from every path in the tube, enumerated: each path's crossing row of
    every anti-diagonal (a cell's row, or row - 0.5 half-way along a diagonal step over it).
    A held row (``held[i]``, below the path's first row) is entered only from straight above,
    at ``pen`` and no local cost."""
    tube = tube_band(band, path, radius)
    r0, r1 = int(path[0, 0]), int(path[-1, 0])
    cells = {(i, j) for i in range(r0, r1 + 1) for j in range(tube.lo[i], tube.hi[i] + 1)}
    paths = _paths(tuple(path[0]), tuple(path[-1]), cells)
    if held is not None:
        paths = [p for p in paths if all(not (held[i] and i > r0) or (i == a + 1 and j == b)
                                         for (a, b), (i, j) in zip(p, p[1:]))]
    costs = []
    for p in paths:
        c = C[p[0]]
        for (a, b), (i, j) in zip(p, p[1:]):
            if held is not None and held[i] and i > r0:
                c += pen
            elif i == a + 1 and j == b + 1:
                c += C[i, j]
            elif i == a + 1:
                c += C[i, j] + pen
            else:
                c += hw * C[i, j] + pen
        costs.append(c)
    w = np.exp(-(np.array(costs) - min(costs)) / temperature)
    w /= w.sum()
    nd = band.n + band.m
    s0, s1, s2 = np.zeros(nd), np.zeros(nd), np.zeros(nd)
    for p, wt in zip(paths, w):
        cross = {i + j: float(i) for i, j in p}
        for (a, b), (i, j) in zip(p, p[1:]):
            if i == a + 1 and j == b + 1:
                cross[i + j - 1] = i - 0.5
        assert sorted(cross) == list(range(p[0][0] + p[0][1], p[-1][0] + p[-1][1] + 1))  # each once
        for d, x in cross.items():
            s0[d] += wt
            s1[d] += wt * x
            s2[d] += wt * x * x
    d0, d1 = int(path[0].sum()), int(path[-1].sum())
    mean, std = _rows_from_diagonals(s0, s1, s2, d0, d1, band.n)
    return mean, std, len(paths)


@pytest.mark.parametrize("pen,hw", [(0.0, 1.0), (0.7, 1.0), (0.0, 0.5), (0.3, 0.25)])
@pytest.mark.parametrize("temperature", [0.5, 2.0])
@pytest.mark.parametrize("radius", [1, 10])
def test_posterior_matches_enumeration(rng, pen, hw, temperature, radius):
    n, m = 5, 7
    C = rng.integers(0, 4, size=(n, m)).astype(float) + rng.uniform(0, 0.3, size=(n, m))
    band = make_band(n, m, 4.0)
    res = dtw(C, band, step_penalty=pen, horizontal_weight=hw)
    post = path_posterior(_matrix_cost(C), band, res.path, temperature=temperature, radius=radius,
                          step_penalty=pen, horizontal_weight=hw)
    mean, std, count = _reference(C, band, res.path, temperature, radius, pen, hw)
    assert count > 1
    np.testing.assert_allclose(post.mean, mean, atol=1e-6)  # costs are kept as float32
    np.testing.assert_allclose(post.std, std, atol=1e-6)


@pytest.mark.parametrize("pen,hw", [(0.0, 1.0), (0.3, 0.25)])
@pytest.mark.parametrize("radius", [1, 10])
def test_posterior_with_held_rows_matches_enumeration(rng, pen, hw, radius):
    """A body hold (rows 2-3 held): paths cross it straight down for free, in the DTW and in the
    expected path alike."""
    n, m = 6, 7
    C = rng.integers(0, 4, size=(n, m)).astype(float) + rng.uniform(0, 0.3, size=(n, m))
    band = make_band(n, m, 4.0)
    held = np.zeros(n, bool)
    held[2:4] = True
    res = dtw(C, band, step_penalty=pen, horizontal_weight=hw, held_rows=held)
    post = path_posterior(_matrix_cost(C), band, res.path, temperature=1.0, radius=radius,
                          step_penalty=pen, horizontal_weight=hw, held_rows=held)
    mean, std, count = _reference(C, band, res.path, 1.0, radius, pen, hw, held)
    assert count > 1
    np.testing.assert_allclose(post.mean, mean, atol=1e-6)
    np.testing.assert_allclose(post.std, std, atol=1e-5)  # the sqrt of a float32 variance near 0: 1e-6 off
    plain = path_posterior(_matrix_cost(C), band, res.path, temperature=1.0, radius=radius,
                           step_penalty=pen, horizontal_weight=hw)
    assert np.abs(plain.mean - post.mean).max() > 1e-3  # the hold changes the answer


@pytest.mark.parametrize("pieces", [1, 7, 1000])
def test_the_backward_sweep_in_pieces_gives_the_same_sums_and_moves_the_bar(rng, monkeypatch, pieces):
    """The backward sweep carries one row of sums from piece to piece: 1, 7 or a piece per row
    give the same expected path and spread to the bit; the bar rises to 1 after the last piece."""
    from splicer.align import posterior

    n, m = 300, 420
    C = rng.uniform(0, 3, size=(n, m))
    band = make_band(n, m, 60.0)
    path = dtw(C, band).path
    kw = dict(temperature=1.5, radius=40)
    monkeypatch.setattr(posterior, "BACKWARD_PIECES", 1)
    one = path_posterior(_matrix_cost(C), band, path, **kw)
    monkeypatch.setattr(posterior, "BACKWARD_PIECES", pieces)
    seen = []
    got = path_posterior(_matrix_cost(C), band, path, progress=seen.append, **kw)
    np.testing.assert_array_equal(got.mean, one.mean)
    np.testing.assert_array_equal(got.std, one.std)
    back = [f for f in seen if f > 0.6]
    assert seen == sorted(seen) and 0.6 in seen and len(back) == min(pieces, n) and back[-1] == 1.0


def test_tied_paths_worked_answer():
    """3 x 2, every cell free: five paths tie (V D, D V, V V H, V H V, H V V; weights 1/5).

    Anti-diagonal 1 is crossed at rows 1, 0.5, 1, 1, 0 (mean 0.7, so column 0.3) and
    anti-diagonal 2 at rows 1.5, 1, 2, 1, 1 (mean 1.3, column 0.7): the expected path runs
    (0, 0), (0.7, 0.3), (1.3, 0.7), (2, 1) and reads 0.5 at row 1, half-way, as the symmetry says."""
    C = np.zeros((3, 2))
    band = make_band(3, 2, 10.0)
    post = path_posterior(_matrix_cost(C), band, np.array([[0, 0], [1, 0], [2, 1]]), temperature=1.0, radius=5)
    np.testing.assert_allclose(post.mean, [0.0, 0.5, 1.0], atol=1e-12)
    # a large step penalty leaves the two paths with one diagonal step (V D and D V) alone:
    # anti-diagonal 1 at rows 1 and 0.5, anti-diagonal 2 at rows 1.5 and 1: the path
    # (0, 0), (0.75, 0.25), (1.25, 0.75), (2, 1) reads 0.5 at row 1 again
    post = path_posterior(_matrix_cost(C), band, np.array([[0, 0], [1, 0], [2, 1]]), temperature=1.0, radius=5,
                          step_penalty=50.0)
    np.testing.assert_allclose(post.mean, [0.0, 0.5, 1.0], atol=1e-12)
    # the cost of cell (1, 1) tips it: only paths through (1, 0) remain (V D, V V H, V H V)
    C[1, 1] = C[0, 1] = 1e4
    post = path_posterior(_matrix_cost(C), band, np.array([[0, 0], [1, 0], [2, 1]]), temperature=1.0, radius=5)
    # d=1 at row 1 (all three); d=2 at rows 1.5, 2, 1 -> 1.5: the path (0,0), (1,0), (1.5,0.5), (2,1)
    np.testing.assert_allclose(post.mean, [0.0, 0.0, 1.0], atol=1e-9)


def test_identical_takes_give_the_diagonal_exactly(rng):
    """A symmetric cost (the same take on both axes): the expected path is the diagonal, ends included."""
    x = rng.normal(size=(40, 3))
    C = ((x[:, None, :] - x[None, :, :]) ** 2).sum(-1).round(1)
    C[5:15, 5:15] = 0.0  # a still stretch: everything there ties
    band = make_band(40, 40, 12.0)
    res = dtw(C, band)
    post = path_posterior(_matrix_cost(C), band, res.path, temperature=3.0, radius=6)
    np.testing.assert_allclose(post.mean, np.arange(40), atol=1e-9)


def test_cold_posterior_is_the_best_path():
    """As the temperature falls, the expected path is the best path: a row it crosses at one
    cell reads that cell's column with no spread; a row it runs along reads a column of that run."""
    rng = np.random.default_rng(3)
    n, m = 30, 45
    C = rng.uniform(0, 5, size=(n, m))
    band = make_band(n, m, 12.0)
    res = dtw(C, band)
    post = path_posterior(_matrix_cost(C), band, res.path, temperature=1e-3, radius=4)
    for i in range(n):
        js = res.path[res.path[:, 0] == i, 1]
        if len(js) == 1:
            assert post.mean[i] == pytest.approx(js[0], abs=1e-3) and post.std[i] < 1e-2, i
        else:
            assert js.min() - 1e-3 <= post.mean[i] <= js.max() + 1e-3, i


def test_tube_stays_in_the_band_and_keeps_pins():
    """The tube is the best path +- radius, clipped to the band: a pin's window (band rows
    narrowed to y +- T) bounds every path the posterior weighs."""
    from splicer.align.band import Constraint

    n, m = 40, 50
    band = make_band(n, m, 20.0, [Constraint(20, 26, 1)])
    C = np.random.default_rng(0).uniform(0, 3, size=(n, m))
    res = dtw(C, band)
    tube = tube_band(band, res.path, 8)
    assert np.all(tube.lo >= band.lo) and np.all(tube.hi <= band.hi)
    assert tube.lo[20] >= 25 and tube.hi[20] <= 27  # the pin's window, T = 1 around 26
    post = path_posterior(_matrix_cost(C), band, res.path, temperature=5.0, radius=8)
    assert 25 <= post.mean[20] <= 27
    assert tube.lo[0] == 0 and tube.hi[-1] == m - 1


def test_open_path_rows_outside_are_nan():
    """An open-ended path covering rows 3..8: the posterior is NaN elsewhere and the ends are the path's."""
    C = np.ones((12, 12))
    band = Band(n=12, m=12, width=12.0, lo=np.zeros(12, np.int64), hi=np.full(12, 11, np.int64),
                open_begin=True, open_end=True)
    path = np.array([[3, 2], [4, 3], [5, 4], [6, 5], [7, 6], [8, 7]])
    post = path_posterior(_matrix_cost(C), band, path, temperature=1.0, radius=2)
    assert np.all(np.isnan(post.mean[:3])) and np.all(np.isnan(post.mean[9:]))
    assert post.mean[3] >= 2 and post.mean[8] <= 7
    np.testing.assert_allclose(post.mean[3:9], post.mean[3:9][::-1].max() - (post.mean[3:9][::-1] - post.mean[3:9].min()),
                               atol=1e-9)  # the uniform cost is symmetric about the path's middle


@pytest.mark.parametrize("kw,msg", [({"temperature": 0.0, "radius": 2}, "temperature"),
                                    ({"temperature": np.inf, "radius": 2}, "temperature"),
                                    ({"temperature": 1.0, "radius": -1}, "radius")])
def test_bad_arguments(kw, msg):
    band = make_band(3, 3, 5.0)
    with pytest.raises(ValueError, match=msg):
        path_posterior(_matrix_cost(np.zeros((3, 3))), band, np.array([[0, 0], [1, 1], [2, 2]]), **kw)


def test_splice_is_smooth_in_its_input():
    """1e-5 degrees of noise on every rotation channel of the bundled sample (far below capture
    noise: Blender's float32 round trip) moves the time map by hundredths of a hands frame and the
    fingers by hundredths of a degree (measured over seeds 0-2: 0.012-0.020 frames and 0.043-0.059
    deg with one pass 1 for both arms, whose time map runs through faster finger motion; 0.010-0.015
    frames and 0.016-0.019 deg with each side alone).  The best path alone moved them by up to 3
    frames and 5.4 deg: D1's near-equal paths swapped."""
    from pathlib import Path

    from splicer.io.bvh import read_bvh
    from splicer.model.rotations import quat_angle_deg
    from splicer.pipeline import splice

    root = Path(__file__).resolve().parents[1] / "motions"
    body, hands = read_bvh(root / "sample_body.bvh"), read_bvh(root / "sample_hands.bvh")
    sync = root / "sample_sync.yaml"

    def noisy(m, rng):
        cols = [c for j in range(m.skeleton.n_joints) for c in m.skeleton.rotation_columns(j)]
        ch = np.array(m.channels)
        ch[:, cols] += rng.normal(0.0, 1e-5, size=(m.n_frames, len(cols)))
        return m.with_channels(ch)

    ref = splice(body, hands, config=sync)
    rng = np.random.default_rng(0)
    got = splice(noisy(body, rng), noisy(hands, rng), config=sync)
    for side in ref.sides:
        assert np.nanmax(np.abs(got.sides[side].hands_frame - ref.sides[side].hands_frame)) < 0.05, side
    assert quat_angle_deg(got.motion.rotations, ref.motion.rotations).max() < 0.08


def test_temperature_is_per_second_of_body_time(monkeypatch):
    """``temperature_s`` 0.8 at a 30 fps body is 24 D1 units per e-fold (0.8 s x 30 frames), the
    tube's radius is ``posterior_radius_s`` in body frames, and 0 keeps the best path."""
    from pathlib import Path

    import splicer.align.posterior as P
    from splicer.io.bvh import read_bvh
    from splicer.pipeline import splice

    seen = []
    real = P.expected_frames

    def spy(p, *, temperature, radius, progress=None):
        seen.append((temperature, radius))
        return real(p, temperature=temperature, radius=radius, progress=progress)

    monkeypatch.setattr(P, "expected_frames", spy)
    root = Path(__file__).resolve().parents[1] / "motions"
    body, hands = read_bvh(root / "sample_body.bvh"), read_bvh(root / "sample_hands.bvh")
    assert body.fps == pytest.approx(30.0)
    stages = []
    r = splice(body, hands, side="left", temperature_s=0.8, posterior_radius_s=2.0,
               progress=lambda stage, f: stages.append((stage, f)))
    # one call per alignment: the left side alone skips both takes' heads, and the partial
    # overlap's check (splicer.stages.overlap) aligns it once more on one take's ends
    assert seen == [(pytest.approx(24.0), 60)] * len(seen) and 1 <= len(seen) <= 2
    shown = [f for stage, f in stages if stage == "left: expected"]
    assert shown and shown == sorted(shown) and 0 < shown[-1] <= 1  # the bar moves while the tube is costed
    assert r.sides["left"].alignment.posterior is not None
    seen.clear()
    r = splice(body, hands, side="left", temperature_s=0.0)
    assert seen == [(0.0, 60)] * len(seen) and seen and r.sides["left"].alignment.posterior is None
