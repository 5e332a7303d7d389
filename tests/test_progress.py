"""The progress a splice reports (what the command's bar shows): every long stage moves, in order."""

from pathlib import Path

import pytest

from splicer import splice

MOTIONS = Path(__file__).resolve().parents[1] / "motions"


def _stages(prefer_loaded: bool):
    from splicer.io import bvh_read

    seen = []
    with pytest.MonkeyPatch.context() as mp:
        # small files: np.loadtxt, unless an earlier test loaded the compiled parser (then it reads them)
        mp.setattr(bvh_read, "PREFER_LOADED", prefer_loaded)
        splice(str(MOTIONS / "sample_body.bvh"), str(MOTIONS / "sample_hands.bvh"),
               progress=lambda stage, f: seen.append((stage, f)))
    return seen


@pytest.fixture(scope="module")
def stages():
    return _stages(False)


def _fractions(stages, name):
    return [f for s, f in stages if s == name]


def test_the_dropout_search_moves_the_bar(stages):
    f = _fractions(stages, "checks: dropouts")
    assert len(f) > 2 and f == sorted(f) and f[0] == 0.0 and f[-1] < 0.5  # the handedness check is the second half
    assert _fractions(stages, "checks: handedness") == [0.5]


@pytest.mark.parametrize("side", ["left", "right"])
def test_the_transfer_and_the_finger_check_move_the_bar(stages, side):
    assert _fractions(stages, f"{side}: transfer") == [0.0, 0.3, 0.6, 0.8]
    assert _fractions(stages, f"{side}: finger check") == [0.0, 0.5]
    names = [s for s, _ in stages]
    assert names.index(f"{side}: transfer") < names.index(f"{side}: finger check")  # in the order they run


def test_reading_moves_the_bar_by_bytes(stages):
    body, hands = (MOTIONS / "sample_body.bvh").stat().st_size, (MOTIONS / "sample_hands.bvh").stat().st_size
    share = 0.3  # splicer.io.bvh_read.READ_SHARE: reading the bytes, then parsing them
    t = body + hands
    assert _fractions(stages, "read") == pytest.approx([0.0, share * body / t, body / t, (body + share * hands) / t, 1.0])


def test_reading_with_the_compiled_parser_moves_the_bar_by_bytes_too():
    """The compiled parser (loaded in splice-server) also reports its parsing: the same points, more between."""
    import splicer.io.fastparse  # noqa: F401

    body, hands = (MOTIONS / "sample_body.bvh").stat().st_size, (MOTIONS / "sample_hands.bvh").stat().st_size
    share, t = 0.3, body + hands
    f = _fractions(_stages(True), "read")
    assert f == sorted(f) and f[0] == 0.0 and f[-1] == 1.0
    for point in (share * body / t, body / t, (body + share * hands) / t):
        assert point == pytest.approx(min(f, key=lambda x: abs(x - point)))


@pytest.mark.parametrize("side", ["left", "right"])
def test_the_markers_move_the_bar_by_frames(stages, side):
    body, hands = 601, 1985  # frames of the bundled sample's takes: the body's markers, then the hands'
    assert _fractions(stages, f"{side}: markers") == [0.0, pytest.approx(body / (body + hands)), 1.0]


def test_stages_end_with_done(stages):
    assert stages[-1] == ("done", 1.0)


def test_no_bar_goes_back(stages):
    """A stage run again (pass 1 end to end after the open-ended pass, the pair aligned again
    with other smoothing) has its own label, so every label's bar only moves forward."""
    labels = {}
    for s, f in stages:
        labels.setdefault(s, []).append(f)
    assert {s: f for s, f in labels.items() if f != sorted(f)} == {}
    # the bundled sample runs both: its takes start and end together, and its hands disagree
    # enough for the smoothing's second opinion (the summary says so too)
    assert "both hands: pass 1, end to end" in labels and "both hands: check (ends)" in labels
    assert "smoothed again: both hands: pass 1" in labels and "smoothed again: left: pass 2" in labels
    names = [s for s, _ in stages]
    assert names.index("both hands: pass 1") < names.index("both hands: pass 1, end to end") \
        < names.index("smoothed again: both hands: pass 1")


def test_an_aside_log_prefixes_its_progress_and_keeps_its_own_warnings():
    from splicer.stages.log import Log

    seen = []
    log = Log(lambda stage, f: seen.append((stage, f)))
    other = log.aside("tempo-matched")
    other.progress("both hands: pass 1", 0.5)
    other.note("only if kept")
    log.progress("left: wrist", 1.0)
    assert seen == [("tempo-matched: both hands: pass 1", 0.5), ("left: wrist", 1.0)]
    assert other.warnings == ["only if kept"] and log.warnings == []
    assert Log().aside("x")._progress is None  # no bar: nothing to prefix


def test_the_command_line_bar_covers_a_longer_line_before_it():
    import io

    from splicer.cli import _Progress

    class Terminal(io.StringIO):
        def isatty(self):
            return True

    out = Terminal()
    bar = _Progress(out, True)
    bar("tempo-matched: both hands: expected", 0.5)
    long_line = out.getvalue()[1:]
    bar("left: wrist", 1.0)
    short_line = out.getvalue()[1 + len(long_line) + 1:]
    assert len(short_line) == len(long_line) and short_line.startswith("left: wrist") and short_line.endswith(" ")
    bar.close()
    assert out.getvalue().endswith("\r" + " " * len(long_line) + "\r")
