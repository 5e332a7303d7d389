"""Every real body with every real hand file through the command line: exit 0, or exit 1 with
one clear line -- never a traceback (issue 9).  Reads ../shared/motions; skips when absent."""

from __future__ import annotations

import json

import pytest

from splicer import defaults as D
from splicer.cli import main

from conftest import SHARED_MOTIONS, SHARED_SKIP_REASON

BODY_DIRS = ("zeggs", "movin", "cmu")
HAND_DIRS = ("leap-hands", "manipnet-hands")


def _files(dirs) -> list:
    if not SHARED_MOTIONS.is_dir():
        return []
    return sorted(p for d in dirs for p in (SHARED_MOTIONS / d).glob("*.bvh"))


def _pairs():
    bodies = _files(BODY_DIRS)
    hands = _files(HAND_DIRS) + bodies  # full bodies serve as hands files too
    if not bodies:
        return [pytest.param(None, None, id="no-shared-motions", marks=pytest.mark.skip(reason=SHARED_SKIP_REASON))]
    return [pytest.param(b, h, id=f"{b.parent.name}/{b.stem}+{h.parent.name}/{h.stem}") for b in bodies for h in hands]


@pytest.mark.shared
@pytest.mark.parametrize(("body", "hands"), _pairs())
def test_every_real_pair_splices_or_is_refused_in_one_line(body, hands, tmp_path, capsys):
    # a full body as the hands file: one side is enough to show it splices (both sides run the same code)
    side = ["--side", "right"] if hands.parent.name in BODY_DIRS else []
    rep = tmp_path / "r.json"
    rc = main([str(body), str(hands), "-o", str(tmp_path / "out.bvh"), "--report", str(rep), "-q", *side])
    err = capsys.readouterr().err
    assert "Traceback" not in err
    if rc == 0:
        assert (tmp_path / "out.bvh").stat().st_size > 0
        # every shared file is a different performance but for a take paired with itself: the check against
        # the hands played backwards tells them apart (self-pairs 0.00-0.01, the others 0.94-1.06)
        report = json.loads(rep.read_text())
        ratios = {s: d["pass1"]["backwards_ratio"] for s, d in report["sides"].items()}
        warned = any("may not show the same performance" in w for w in report["warnings"])
        if body == hands:
            assert all(r < 0.1 for r in ratios.values()) and not warned, ratios
        else:
            assert all(r >= D.BACKWARDS_RATIO for r in ratios.values()) and warned, ratios
    else:
        assert rc == 1, err
        lines = err.strip().splitlines()
        assert len(lines) == 1 and lines[0].startswith("splice: error: "), err
