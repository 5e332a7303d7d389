"""splicer.plot: band images by hand, and the plot of a real splice: its scene and its pixels."""

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


def test_plot_writes_a_png_of_the_stated_size(sample_result, tmp_path):
    out = tmp_path / "align.png"
    plot_alignment(sample_result, out, dpi=50)
    # one row per side; pass 1, pass 2 and the time map: 3 x 4.2 in by 3.6 in per side, at 50 dpi
    rows = len(sample_result.sides)
    assert _png_size(out) == (round(3 * 4.2 * 50), round(rows * 3.6 * 50))
    assert [p.name for p in tmp_path.iterdir()] == ["align.png"]  # no temporary file left


def test_plot_refuses_an_empty_result_and_names_an_unwritable_path(sample_result, tmp_path):
    class Empty:
        sides = {}

    with pytest.raises(SplicerError, match="nothing to plot"):
        plot_alignment(Empty(), tmp_path / "x.png")
    with pytest.raises(SplicerError, match="cannot write the plot"):
        plot_alignment(sample_result, tmp_path / "no-such-dir" / "x.png")


def test_plot_content_axes_shading_and_few_ticks(sample_result):
    """Per side: two band images with their colour bars and a time map whose shaded ranges are
    one group per kind (however many runs), and at most 7 ticks an axis."""
    from splicer.pipeline import LOW_CONFIDENCE_S
    from splicer.plot import figure
    from splicer.transfer.timemap import frame_ranges

    fig = figure(sample_result, dpi=40)
    sides = list(sample_result.sides.values())
    assert len(fig.axes) == 5 * len(sides)  # pass 1 + colour bar, pass 2 + colour bar, time map
    maps = [ax for ax in fig.axes if ax.title.endswith("time map")]
    assert len(maps) == len(sides)
    for ax, s in zip(maps, sides):
        low = np.isfinite(s.alignment.confidence.est_error_s) & (s.alignment.confidence.est_error_s > LOW_CONFIDENCE_S)
        ranges = frame_ranges(low)
        assert ranges  # the sample has low-confidence frames on both sides
        shades = [sp for sp in ax.spans if sp.label.startswith("low confidence")]
        assert len(shades) == 1 and len(shades[0].ranges) == len(ranges)
        assert shades[0].ranges[0] == (ranges[0][0] - 0.5, ranges[0][1] + 0.5)
        assert ax.legend_size and [ln.label for ln in ax.lines] == ["hands frame used", "uniform time scaling"]
        np.testing.assert_array_equal(ax.lines[0].y, s.hands_frame)
        assert not [sp for sp in ax.spans if sp.label == "no hands material"]  # the sample is covered throughout
    passes = [ax for ax in fig.axes if ax.images and not ax.ticks_right]
    assert len(passes) == 2 * len(sides) and all(len(ax.images) == 1 for ax in passes)
    assert [ax.title.split(":")[1].split(",")[0].strip() for ax in passes[:2]] == ["pass 1", "pass 2"]
    for ax in passes:  # the chosen path in red over the band image, the band's two edges in white
        assert [ln.color for ln in ax.lines] == [(255, 255, 255), (255, 255, 255), (255, 0, 0)]
    assert len([ax for ax in fig.axes if ax.ticks_right]) == 2 * len(sides)  # colour bars
    for ax in fig.axes:
        assert len(ax.yticks()) <= 7 and len(ax.xticks()) <= 7


def test_plot_pixels_show_the_shading_and_the_band(sample_result, tmp_path):
    """The drawn PNG: a low-confidence body frame's column on the time map is tinted red, a
    confident one is not; inside pass 1's band the cost colours, outside it white."""
    from PIL import Image

    from splicer.pipeline import LOW_CONFIDENCE_S
    from splicer.plot import figure

    fig = figure(sample_result, dpi=60)
    plot_alignment(sample_result, tmp_path / "p.png", dpi=60)
    with Image.open(tmp_path / "p.png") as im:
        px = np.asarray(im.convert("RGB")).astype(int)
    W, H = fig.size_px
    s = next(iter(sample_result.sides.values()))
    tmap = next(ax for ax in fig.axes if ax.title.endswith("time map"))
    (xa, xb), _ = tmap.limits()
    l, b, w, h = tmap.rect
    low = np.isfinite(s.alignment.confidence.est_error_s) & (s.alignment.confidence.est_error_s > LOW_CONFIDENCE_S)

    def column(frame):  # pixel column of a body frame on the time map
        return round((l + (frame - xa) / (xb - xa) * w) * W)

    y = round((1 - b - 0.15 * h) * H)  # near the bottom, away from the legend and the map's line
    flagged = next(i for i in range(2, len(low) - 2) if low[i - 2:i + 3].all())
    calm = next(i for i in range(2, len(low) - 2) if not low[i - 2:i + 3].any())
    r, g, bl = px[y, column(flagged)]
    assert r > 240 and g < 230 and bl < 230  # white under red at 0.2: (245, 215, 215)
    assert px[y, column(calm)].tolist() == [255, 255, 255]
    p1 = next(ax for ax in fig.axes if ": pass 1" in ax.title)
    (xa, xb), (ya, yb) = p1.limits()
    l, b, w, h = p1.rect
    i = len(s.hands_frame) // 2
    j = float(s.pass1.path[s.pass1.path[:, 0] == i][0, 1])  # on the chosen path: inside the band
    x = round((l + (i - xa) / (xb - xa) * w) * W)
    inside = px[round((1 - b - (j + 0.3 * s.pass1.band.width - ya) / (yb - ya) * h) * H), x]
    jo = min(j + 3 * s.pass1.band.width, ya + 0.95 * (yb - ya))
    assert s.pass1.band.lo[i] < j + 0.3 * s.pass1.band.width < s.pass1.band.hi[i] < jo
    outside = px[round((1 - b - (jo - ya) / (yb - ya) * h) * H), x]
    assert inside.tolist() != [255, 255, 255] and outside.tolist() == [255, 255, 255]
