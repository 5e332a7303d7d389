"""splicer._chart: worked answers for ticks, labels, colours and dashes, and pixels of small
figures whose every colour can be worked out by hand."""

import numpy as np
import pytest

from splicer._chart import Figure, nice_ticks, tick_labels, viridis
from splicer._paint import _dashes


@pytest.mark.parametrize("lo, hi, kw, want", [
    (0, 600, {}, [0, 200, 400, 600]),  # step 100 would give 7 ticks: the next, 200
    (0, 1985, {}, [0, 500, 1000, 1500]),
    (-30, 630, {}, [0, 200, 400, 600]),  # matplotlib's 5 % margins around 0..600
    (0.05, 1.83, {}, [0.5, 1.0, 1.5]),  # steps 0.1, 0.2, 0.25 give 18, 9, 7 ticks: 0.5
    (0.0, 1.0, {}, [0.0, 0.2, 0.4, 0.6, 0.8, 1.0]),
    (0, 3, {"integer": True}, [0, 1, 2, 3]),  # 0.5 or 0.25 would be finer, but not whole
    (-5, 5, {}, [-4, -2, 0, 2, 4]),
])
def test_nice_ticks(lo, hi, kw, want):
    np.testing.assert_allclose(nice_ticks(lo, hi, **kw), want)


def test_nice_ticks_degenerate_ranges():
    assert nice_ticks(2.0, 2.0).tolist() == [2.0]
    assert nice_ticks(np.nan, 1.0).tolist() == []


def test_tick_labels_take_the_decimals_the_step_needs():
    assert tick_labels(np.array([0.0, 200.0, 400.0])) == ["0", "200", "400"]
    assert tick_labels(np.array([0.4, 0.8, 1.2])) == ["0.4", "0.8", "1.2"]
    assert tick_labels(np.array([-0.25, 0.0, 0.25])) == ["-0.25", "0.00", "0.25"]
    assert tick_labels(np.array([-1e-17, 1.0])) == ["0", "1"]  # no '-0'
    assert tick_labels(np.array([])) == []


def test_viridis_ends_middle_clipping_and_nan():
    got = viridis(np.array([[-1.0, 0.0, 5.0], [10.0, 20.0, np.nan]]), 0.0, 10.0)
    assert got.shape == (2, 3, 3) and got.dtype == np.uint8
    assert got[0, 0].tolist() == got[0, 1].tolist() == [68, 1, 84]  # below vmin: the low end
    assert got[0, 2].tolist() == [33, 145, 140]  # 0.5: the map's 9th of 17 points
    assert got[1, 0].tolist() == got[1, 1].tolist() == [253, 231, 37]
    assert got[1, 2].tolist() == [255, 255, 255]
    assert viridis(np.array([3.0]), 3.0, 3.0).tolist() == [[68, 1, 84]]  # an empty range: no division by zero


def test_dashes_of_a_straight_line():
    # 10 pixels, dashes 3 long with gaps of 2: 0-3 drawn, 3-5 gap, 5-8 drawn, 8-10 gap
    assert _dashes([(0, 0), (10, 0)], 3, 2) == [[(0, 0), (3.0, 0.0)], [(5.0, 0.0), (8.0, 0.0)]]
    # a corner inside a dash: the dash keeps the corner point
    assert _dashes([(0, 0), (2, 0), (2, 2)], 3, 10) == [[(0, 0), (2, 0), (2.0, 1.0)]]


def _pixels(fig):
    return np.asarray(fig.render()).astype(int)


def test_an_image_lands_on_its_extent_row_zero_at_the_bottom():
    # 40 x 40 pixels, one axes over all of it, a 2 x 2 image over the whole view: four quadrants
    fig = Figure(2.0, 2.0, 20)
    ax = fig.add_axes([0, 0, 1, 1])
    im = ax.imshow(np.array([[0.0, 1.0], [2.0, np.nan]]), extent=(0, 2, 0, 2))
    ax.xlim, ax.ylim, ax.show_x = (0, 2), (0, 2), False
    assert (im.vmin, im.vmax) == (0.0, 2.0)  # NaN ignored
    px = _pixels(fig)
    assert px.shape == (40, 40, 3)
    assert px[30, 10].tolist() == [68, 1, 84]  # bottom left: data[0, 0] = 0, the low end
    assert px[30, 30].tolist() == viridis(np.array([1.0]), 0, 2)[0].tolist()  # bottom right: data[0, 1]
    assert px[10, 10].tolist() == [253, 231, 37]  # top left: data[1, 0] = 2, the high end
    assert px[10, 30].tolist() == [255, 255, 255]  # top right: NaN


def test_an_image_smaller_than_the_view_leaves_white_around_it():
    fig = Figure(2.0, 2.0, 20)
    ax = fig.add_axes([0, 0, 1, 1])
    ax.imshow(np.zeros((1, 1)), extent=(0, 1, 0, 1))
    ax.xlim, ax.ylim, ax.show_x = (0, 2), (0, 2), False
    px = _pixels(fig)
    assert px[30, 10].tolist() == [68, 1, 84] and px[10, 30].tolist() == [255, 255, 255]


def test_lines_and_spans_are_clipped_to_their_axes():
    # axes over the middle half of a 40 x 40 figure (pixels 10..30); a line at y = 0.5 from x = -10 to 10
    fig = Figure(2.0, 2.0, 20)
    ax = fig.add_axes([0.25, 0.25, 0.5, 0.5])
    ax.xlim, ax.ylim, ax.show_x = (0, 1), (0, 1), False
    ax.plot([-10, 10], [0.5, 0.5], (0, 0, 0), 3.0)
    ax.axvspans([(0.0, 0.5)], (255, 0, 0), 0.5)
    px = _pixels(fig)
    assert px[20, 20].tolist() == [0, 0, 0]  # the line, in the axes
    assert px[20, 5].tolist() == px[20, 35].tolist() == [255, 255, 255]  # not outside them
    assert px[14, 14].tolist() == [255, 127, 127]  # the span: red at opacity 128/255 on white
    assert px[14, 26].tolist() == [255, 255, 255]  # right of the span
    assert px[5, 14].tolist() == [255, 255, 255]  # above the axes: the span stops at their top


def test_limits_default_to_the_data_with_margins():
    ax = Figure(1, 1, 10).add_axes([0, 0, 1, 1])
    ax.plot([0, 10], [2, np.nan], (0, 0, 0), 1.0)
    ax.errorbar([5], [4], [1], (0, 0, 0))
    (x0, x1), (y0, y1) = ax.limits()
    assert (x0, x1) == (-0.5, 10.5)
    assert (y0, y1) == pytest.approx((2 - 0.15, 5 + 0.15))  # 2..5 (the bar's top), 5 % of 3 each side


def test_colorbar_shows_the_images_range_with_its_label():
    fig = Figure(2.0, 2.0, 20)
    ax, cax = fig.add_axes([0.1, 0.1, 0.5, 0.8]), fig.add_axes([0.7, 0.1, 0.1, 0.8])
    im = ax.imshow(np.array([[0.0, 4.0]]), extent=(0, 1, 0, 1))
    fig.colorbar(im, cax, "cost")
    assert cax.ylim == (0.0, 4.0) and cax.ylabel == "cost" and cax.ticks_right
    assert cax.yticks().tolist() == [0, 1, 2, 3, 4] and cax.xticks().size == 0
    px = _pixels(fig)
    x = 30  # the bar's middle column (pixels 28..32)
    assert px[34, x].tolist() == [68, 1, 84] or px[34, x, 2] < 120  # near the bottom: dark
    assert px[5, x, 0] > 200 and px[5, x, 1] > 200  # near the top: yellow


def test_save_writes_a_png_of_the_stated_size(tmp_path):
    fig = Figure(4.2, 3.6, 50)
    ax = fig.add_axes([0.2, 0.2, 0.7, 0.7])
    ax.plot([0, 1, 2], [0, 1, 4], (0, 0, 0), 1.0, dashed=True, label="dashed")
    ax.title, ax.xlabel, ax.ylabel, ax.legend_size = "a title", "x", "y", 7
    fig.save(tmp_path / "f.png")
    from PIL import Image

    with Image.open(tmp_path / "f.png") as im:
        assert im.format == "PNG" and im.size == (210, 180) == fig.size_px


def test_text_falls_back_to_pillows_font_without_matplotlibs(tmp_path, monkeypatch):
    from splicer import _paint

    monkeypatch.setattr(_paint, "_font_file", lambda: None)
    monkeypatch.setattr(_paint, "_FONTS", {})
    fig = Figure(2.0, 1.0, 50)
    ax = fig.add_axes([0.3, 0.3, 0.6, 0.5])
    ax.plot([0, 1], [0, 1], (0, 0, 0), 1.0)
    ax.title, ax.ylabel = "title", "y"
    px = _pixels(fig)
    assert px.shape == (50, 100, 3)
    assert (px[:12].sum(axis=2) < 600).any()  # the title's ink above the axes


def test_a_view_of_zero_width_is_widened():
    # a one-frame take: xlim (0, 0) would divide by zero when mapping data to pixels
    fig = Figure(1.0, 1.0, 20)
    ax = fig.add_axes([0.2, 0.2, 0.6, 0.6])
    ax.xlim, ax.ylim = (0, 0), (3, 3)
    ax.plot([0], [3], (0, 0, 0), 1.0)
    ax.imshow(np.array([[1.0]]), extent=(-0.5, 0.5, 2.5, 3.5))
    assert ax.limits() == ((-0.5, 0.5), (2.5, 3.5))
    assert ax.xticks().tolist() == [0.0] and _pixels(fig).shape == (20, 20, 3)


def test_an_image_of_no_extent_is_drawn_as_one_unit_wide():
    # band_image of a one-frame pass has 0 frames per pixel: extent (0, 0)
    fig = Figure(1.0, 1.0, 20)
    ax = fig.add_axes([0, 0, 1, 1])
    ax.imshow(np.array([[5.0]]), extent=(0.0, 0.0, 0.0, 0.0))
    ax.xlim, ax.ylim, ax.show_x = (0, 0), (0, 0), False
    px = _pixels(fig)
    assert px[10, 10].tolist() == [68, 1, 84]  # the one value fills the view: no division by zero, no warning
