"""splicer.plot: band images by hand, and the PNG of a real splice (size, no global state)."""

import struct
from pathlib import Path

import numpy as np
import pytest

from splicer.align.passes import PassResult
from splicer.align.band import make_band
from splicer.errors import SplicerError
from splicer.plot import band_image, plot_alignment

MOTIONS = Path(__file__).resolve().parents[1] / "motions"


def _cost(band, i0, i1):
    """Local cost 10 i + j of every band cell of rows i0..i1-1, as the DTW passes give them."""
    return [10.0 * i + np.arange(band.lo[i], band.hi[i] + 1) for i in range(i0, i1)]


def _pass(n=5, m=5, width=2.0):
    band = make_band(n, m, width)
    return PassResult(np.stack([np.arange(n), np.arange(n)], axis=1), 0.0, band, "pass1", _cost)


def test_band_image_full_resolution():
    # n = m = 5, W = 2: lo = 0 0 1 2 3, hi = 1 2 3 4 4 (see test_band.py); outside the band NaN
    img, rs, cs = band_image(_pass())
    nan = np.nan
    want = [[0, 1, nan, nan, nan],
            [10, 11, 12, nan, nan],
            [nan, 21, 22, 23, nan],
            [nan, nan, 32, 33, 34],
            [nan, nan, nan, 43, 44]]
    np.testing.assert_array_equal(img, want)
    assert (rs, cs) == (1.0, 1.0)


def test_band_image_sampled():
    # at most 3 pixels a side: rows and columns 0, 2, 4 (2 frames per pixel)
    img, rs, cs = band_image(_pass(), max_pixels=3)
    nan = np.nan
    np.testing.assert_array_equal(img, [[0, nan, nan], [nan, 22, nan], [nan, nan, 44]])
    assert (rs, cs) == (2.0, 2.0)
    # 9 rows into 4 pixels: linspace(0, 8, 4) = 0, 2.67, 5.33, 8 -> rows 0, 3, 5, 8; 8/3 per pixel
    img, rs, cs = band_image(_pass(9, 5, 3.0), max_pixels=4)
    assert img.shape == (4, 4) and rs == pytest.approx(8 / 3) and cs == pytest.approx(4 / 3)


def _png_size(path: Path) -> tuple[int, int]:
    head = path.read_bytes()[:24]
    assert head[:8] == b"\x89PNG\r\n\x1a\n" and head[12:16] == b"IHDR"
    return struct.unpack(">II", head[16:24])


@pytest.fixture(scope="module")
def sample_result():
    from splicer import splice

    if not (MOTIONS / "sample_body.bvh").exists():
        pytest.skip("motions/sample_body.bvh is missing")
    return splice(str(MOTIONS / "sample_body.bvh"), str(MOTIONS / "sample_hands.bvh"),
                  config=str(MOTIONS / "sample_sync.yaml"))


def test_plot_writes_a_png_of_the_stated_size_without_touching_pyplot(sample_result, tmp_path):
    import matplotlib
    import matplotlib.pyplot as plt

    backend = matplotlib.get_backend()
    figures = plt.get_fignums()
    out = tmp_path / "align.png"
    plot_alignment(sample_result, out, dpi=50)
    # one row per side; pass 1, pass 2 and the time map: 3 x 4.2 in by 3.6 in per side, at 50 dpi
    rows = len(sample_result.sides)
    assert _png_size(out) == (round(3 * 4.2 * 50), round(rows * 3.6 * 50))
    assert matplotlib.get_backend() == backend
    assert plt.get_fignums() == figures
    assert [p.name for p in tmp_path.iterdir()] == ["align.png"]  # no temporary file left


def test_plot_refuses_an_empty_result_and_names_an_unwritable_path(sample_result, tmp_path):
    class Empty:
        sides = {}

    with pytest.raises(SplicerError, match="nothing to plot"):
        plot_alignment(Empty(), tmp_path / "x.png")
    with pytest.raises(SplicerError, match="cannot write the plot"):
        plot_alignment(sample_result, tmp_path / "no-such-dir" / "x.png")


def test_plot_content_axes_shading_and_few_ticks(sample_result, tmp_path, monkeypatch):
    """Per side: two band images with their colour bars and a time map whose shaded ranges are
    one collection per kind (however many runs), and at most 7 ticks an axis."""
    from matplotlib.collections import PolyCollection
    from matplotlib.figure import Figure

    from splicer.pipeline import LOW_CONFIDENCE_S
    from splicer.transfer.timemap import frame_ranges

    figs = []
    real_savefig = Figure.savefig
    monkeypatch.setattr(Figure, "savefig", lambda self, *a, **k: (figs.append(self), real_savefig(self, *a, **k))[1])
    plot_alignment(sample_result, tmp_path / "p.png", dpi=40)
    (fig,) = figs
    sides = list(sample_result.sides.values())
    assert len(fig.axes) == 5 * len(sides)  # pass 1 + colour bar, pass 2 + colour bar, time map
    maps = [ax for ax in fig.axes if ax.get_title().endswith("time map")]
    assert len(maps) == len(sides)
    for ax, s in zip(maps, sides):
        low = np.isfinite(s.alignment.confidence.est_error_s) & (s.alignment.confidence.est_error_s > LOW_CONFIDENCE_S)
        ranges = frame_ranges(low)
        assert ranges  # the sample has low-confidence frames on both sides
        shades = [c for c in ax.collections if isinstance(c, PolyCollection) and c.get_label().startswith("low confidence")]
        assert len(shades) == 1 and len(shades[0].get_paths()) == len(ranges)
        x0, x1 = shades[0].get_paths()[0].vertices[:, 0].min(), shades[0].get_paths()[0].vertices[:, 0].max()
        assert (x0, x1) == (ranges[0][0] - 0.5, ranges[0][1] + 0.5)
        assert [t.get_text() for t in ax.get_legend().get_texts()][-1].startswith("low confidence")
    images = [im for ax in fig.axes for im in ax.images]
    assert len(images) == 2 * len(sides)
    for ax in fig.axes:
        assert len(ax.yaxis.get_majorticklocs()) <= 7 and not len(ax.yaxis.get_minorticklocs())
