"""Small inputs and checks shared by the bad-input, fault and fuzz tests (issue 10)."""

from __future__ import annotations

import contextlib
import io
import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SAMPLE_BODY = ROOT / "motions" / "sample_body.bvh"
SAMPLE_HANDS = ROOT / "motions" / "sample_hands.bvh"
SAMPLE_SYNC = ROOT / "motions" / "sample_sync.yaml"

#: Small sample takes: 40 body frames at 30 fps, 80 hands frames at 60 fps (same 1.3 s).
BODY_FRAMES, HANDS_FRAMES = 40, 80
#: Constraints that fit the small takes (the sample's pairs are beyond their ends).
SMALL_SYNC = "# small sync\npairs:\n  - {body: 10, hands: 21}\n  - {body: 25, hands: 0.85s, tolerance: 2}\ntolerance: 2\n"


def truncate_bvh(text: str, frames: int) -> str:
    """``text`` (a BVH file) keeping its first ``frames`` data rows, ``Frames:`` updated."""
    lines = text.split("\n")
    i = next(k for k, line in enumerate(lines) if line.startswith("Frames:"))
    lines[i] = f"Frames: {frames}"
    return "\n".join(lines[: i + 2 + frames]) + "\n"


_CACHE: dict = {}


def small_texts() -> tuple[str, str]:
    """(body text, hands text) of the small sample takes."""
    if "texts" not in _CACHE:
        _CACHE["texts"] = (truncate_bvh(SAMPLE_BODY.read_text(), BODY_FRAMES),
                           truncate_bvh(SAMPLE_HANDS.read_text(), HANDS_FRAMES))
    return _CACHE["texts"]


def small_files(folder: Path) -> tuple[Path, Path]:
    """Write the small body and hands takes into ``folder``; returns their paths."""
    body, hands = small_texts()
    b, h = folder / "body.bvh", folder / "hands.bvh"
    b.write_text(body)
    h.write_text(hands)
    return b, h


def run_cli(argv) -> tuple[int, str, str]:
    """``splicer.cli.main(argv)`` in this process: (exit status, stdout, stderr)."""
    from splicer.cli import main

    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            code = main([str(a) for a in argv])
        except SystemExit as e:  # argparse usage errors
            code = e.code if isinstance(e.code, int) else 2
    return code, out.getvalue(), err.getvalue()


TEMP_NAME = re.compile(r"\..*\.splice-\d+-[0-9a-f]+\.(tmp|bak)$")


def temporaries(folder: Path) -> list[str]:
    """Names of splicer temporaries left in ``folder``."""
    return sorted(p.name for p in Path(folder).iterdir() if TEMP_NAME.match(p.name))


def one_error_line(err: str) -> str:
    """The single line of ``err``; fails unless there is exactly one short line."""
    lines = err.strip("\n").split("\n")
    assert len(lines) == 1 and lines[0], f"expected one line, got {len(lines)}: {err[:500]!r}"
    assert len(lines[0]) <= 500, f"message of {len(lines[0])} characters: {lines[0][:200]!r}"
    return lines[0]
