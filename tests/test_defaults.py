"""One place of defaults: the splice, the passes and the feature functions agree."""

import inspect

from splicer import defaults
from splicer.align.passes import pass1, pass2
from splicer.align.costs import phase_features
from splicer.options import SpliceOptions


def _default(func, name):
    return inspect.signature(func).parameters[name].default


def test_feature_functions_and_passes_use_the_splice_defaults():
    # notebook 01 once showed a dead zone of 0.1 (metrics' own default) while the splice used 0.01
    for func in (phase_features, pass1, pass2):
        assert _default(func, "smooth_s") == defaults.SMOOTH_S == 0.025
        assert _default(func, "dead_zone") == defaults.DEAD_ZONE == 0.01


def test_splice_options_match_the_defaults_module():
    o = SpliceOptions()
    # band1 None: defaults.BAND1 (30%) with fixed ends, defaults.OPEN_BAND1 (3 s) with open ends
    assert (o.band1, o.smooth_s, o.dead_zone) == (None, defaults.SMOOTH_S, defaults.DEAD_ZONE)
    assert (defaults.BAND1, defaults.OPEN_BAND1) == ("30%", "3s")
    # guided long takes with fixed ends: 4 s around the coarse path, pass 2 a third of 20 s
    assert (defaults.GUIDED_BAND1, defaults.GUIDED_BAND2_OF) == ("4s", "20s")
    assert (o.pass2_weight, o.pass2_d1_weight) == (defaults.PASS2_WEIGHT, defaults.PASS2_D1_WEIGHT)
    assert (o.timemap_sigma_s, o.blend_window) == (defaults.TIMEMAP_SIGMA_S, defaults.BLEND_WINDOW_FRAMES)
    assert (o.coarse_fps, o.coarse_above_s) == (defaults.COARSE_FPS, defaults.COARSE_ABOVE_S)
