"""The one run finder (splicer.runs.true_runs) against a loop, and its callers' conventions."""

import numpy as np
import pytest

from splicer.rig.dropouts import _runs
from splicer.rig.gapfill import missing_runs
from splicer.runs import true_runs
from splicer.transfer.timemap import frame_ranges


def _loop_runs(mask):
    """Slow reference: walk the mask."""
    out, start = [], None
    for i, v in enumerate(mask):
        if v and start is None:
            start = i
        if not v and start is not None:
            out.append((start, i))
            start = None
    if start is not None:
        out.append((start, len(mask)))
    return out


def test_worked_answer():
    s, e = true_runs(np.array([1, 1, 0, 1, 0, 0, 1, 1, 1], bool))
    assert s.tolist() == [0, 3, 6] and e.tolist() == [2, 4, 9]


@pytest.mark.parametrize("seed", range(20))
def test_against_loop_and_callers(seed):
    rng = np.random.default_rng(seed)
    mask = rng.random(int(rng.integers(0, 40))) < rng.uniform(0.1, 0.9)
    ref = _loop_runs(mask)
    assert list(zip(*(a.tolist() for a in true_runs(mask)))) == ref
    assert missing_runs(mask) == ref  # stop exclusive
    assert _runs(mask) == [(a, b - 1) for a, b in ref]  # inclusive
    assert frame_ranges(mask) == [[a, b - 1] for a, b in ref]


def test_rejects_2d():
    with pytest.raises(ValueError, match="1-D"):
        true_runs(np.zeros((2, 2), bool))
