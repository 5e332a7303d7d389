"""The BVH header: a line scanner with line-numbered errors, cross-checked against bvhio.

:func:`scan_header` checks HIERARCHY and the MOTION header line by line and collects joint
names, offsets, channels and End Sites in float64.  It runs before bvhio because on
malformed input bvhio loops forever (its ``parseLine`` re-reads ``""`` at end of file, so an
empty or truncated file never returns), raises ``IndexError``/``SyntaxError`` without a
usable line, or silently accepts bad input (unknown channel names, a negative Frame Time).
Each complaint is a :class:`~splicer.errors.BVHError` naming the file, the 1-based line and
what was expected.  :func:`cross_check_with_bvhio` then has bvhio (the parser of record)
parse the hierarchy and compares.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field

import numpy as np

from . import limits
from ..errors import BVHError
from .limits import shorten

__all__ = ["CHANNEL_NAMES", "NeedMoreText", "Scan", "number", "scan_header", "cross_check_with_bvhio", "load_bvhio"]

CHANNEL_NAMES = {
    c.lower(): c
    for c in ("Xposition", "Yposition", "Zposition", "Xrotation", "Yrotation", "Zrotation")
}


@dataclass
class Scan:
    """What the line scanner found in the header (lists grow joint by joint)."""

    names: list[str] = field(default_factory=list)
    parents: list[int] = field(default_factory=list)
    offsets: list[list[float]] = field(default_factory=list)
    channels: list[tuple[str, ...]] = field(default_factory=list)
    end_sites: list[list[float]] = field(default_factory=list)
    name_lines: list[int] = field(default_factory=list)
    frames: int = 0
    frames_line: int = 0
    frame_time: float = 0.0
    data_start: int = 0  # 0-based index of the first line after "Frame Time:"

    @property
    def n_channels(self) -> int:
        return sum(len(c) for c in self.channels)


def _show(tokens: list[str]) -> str:
    s = " ".join(tokens)
    return repr(s if len(s) <= 40 else s[:37] + "...")


class NeedMoreText(Exception):
    """The scanner ran past the end of a header prefix that is not the whole file (read more)."""


class _Lines:
    """Iterator over non-blank lines yielding (1-based line number, tokens).

    ``complete`` says whether ``lines`` is the whole file; when it is not, running out of
    lines raises :class:`NeedMoreText` instead of the end-of-file error.
    """

    def __init__(self, lines: list[str], path: str, complete: bool = True):
        self.lines = lines
        self.i = 0
        self.path = path
        self.complete = complete

    def next(self, expected: str) -> tuple[int, list[str]]:
        while self.i < len(self.lines):
            tokens = self.lines[self.i].split()
            self.i += 1
            if tokens:
                return self.i, tokens
        if not self.complete:
            raise NeedMoreText
        last = max((k + 1 for k, t in enumerate(self.lines) if t.strip()), default=1)
        raise BVHError(f"the file ends here (unexpected end of file), expected {expected}",
                       path=self.path, line=last)


def number(tok: str, what: str, path: str, line: int) -> float:
    """A finite number of at most ``limits.MAX_ABS_VALUE`` in magnitude, written in ASCII."""
    v = math.nan
    if tok.isascii() and "_" not in tok and len(tok) <= 64:
        try:
            v = float(tok)
        except ValueError:
            pass
    if not math.isfinite(v):
        raise BVHError(f"{what}: expected a number, found {shorten(tok)}", path=path, line=line)
    if abs(v) > limits.MAX_ABS_VALUE:
        raise BVHError(f"{what}: {shorten(tok)} is too large (the limit is {limits.MAX_ABS_VALUE:g} in "
                       "magnitude)", path=path, line=line)
    return v


def scan_header(lines: list[str], path: str, complete: bool = True) -> Scan:
    """Check HIERARCHY and the MOTION header line by line; collect the skeleton.

    ``lines`` are the file's lines (index i is line i + 1), line endings removed; when
    ``complete`` is false they are only the first lines of the file (ending at a line
    break) and :class:`NeedMoreText` is raised if the header does not end within them.
    """
    src = _Lines(lines, path, complete)
    scan = Scan()
    ln, tok = src.next("HIERARCHY")
    if tok != ["HIERARCHY"]:
        raise BVHError(f"expected HIERARCHY, found {_show(tok)}", path=path, line=ln)
    ln, tok = src.next("ROOT <name>")
    if tok[0] != "ROOT":
        raise BVHError(f"expected ROOT <name>, found {_show(tok)}", path=path, line=ln)
    _scan_joint(src, scan, tok, ln, parent=-1, depth=1)
    ln, tok = src.next("MOTION")
    if tok == ["}"]:
        raise BVHError("unbalanced braces: '}' without a matching '{' (expected MOTION)", path=path, line=ln)
    if tok[0] in ("ROOT", "JOINT"):
        raise BVHError(f"expected MOTION after the root joint, found {_show(tok)} (only one ROOT is supported)",
                       path=path, line=ln)
    if tok != ["MOTION"]:
        raise BVHError(f"expected MOTION, found {_show(tok)}", path=path, line=ln)

    ln, tok = src.next("Frames: <count>")
    joined = " ".join(tok)
    if not joined.startswith("Frames:"):
        raise BVHError(f"expected Frames: <count>, found {_show(tok)}", path=path, line=ln)
    count = joined[len("Frames:"):].strip()
    if not (count.isascii() and count.isdigit()):
        raise BVHError(f"Frames: expected a non-negative whole number, found {shorten(count)}", path=path, line=ln)
    if len(count.lstrip("0")) > 9 or int(count) > limits.MAX_FRAMES:
        raise BVHError(f"Frames: {shorten(count)} is more than the limit of {limits.MAX_FRAMES:,} frames",
                       path=path, line=ln)
    scan.frames, scan.frames_line = int(count), ln
    if scan.frames * scan.n_channels > limits.MAX_VALUES:
        raise BVHError(f"Frames: {scan.frames:,} frames of {scan.n_channels} channels is more than the limit of "
                       f"{limits.MAX_VALUES:,} values", path=path, line=ln)

    ln, tok = src.next("Frame Time: <seconds>")
    joined = " ".join(tok)
    if not (len(tok) >= 2 and tok[0] == "Frame" and tok[1].startswith("Time:")):
        raise BVHError(f"expected Frame Time: <seconds>, found {_show(tok)}", path=path, line=ln)
    value = joined[len("Frame "):].strip()[len("Time:"):].strip()
    ft = number(value, "Frame Time", path, ln) if value else math.nan
    if not ft > 0:
        raise BVHError(f"Frame Time: expected a positive number of seconds, found {shorten(value)}",
                       path=path, line=ln)
    lo, hi = limits.FRAME_TIME_RANGE
    if not lo <= ft <= hi:
        raise BVHError(f"Frame Time: {shorten(value)} seconds is outside the accepted range {lo:g} .. {hi:g} s "
                       f"({1 / hi:g} to {1 / lo:g} frames per second)", path=path, line=ln)
    scan.frame_time = ft
    scan.data_start = src.i
    return scan


def _scan_offset(src: _Lines, what: str) -> list[float]:
    ln, tok = src.next(f"OFFSET x y z of {what}")
    if tok[0] != "OFFSET":
        raise BVHError(f"expected OFFSET x y z of {what}, found {_show(tok)}", path=src.path, line=ln)
    if len(tok) != 4:
        raise BVHError(f"OFFSET of {what}: expected 3 numbers, found {len(tok) - 1}", path=src.path, line=ln)
    return [number(t, f"OFFSET of {what}", src.path, ln) for t in tok[1:]]


def _scan_joint(src: _Lines, scan: Scan, head: list[str], head_line: int, parent: int, depth: int) -> None:
    """Scan one ROOT/JOINT block whose header line ``head`` was just read (recursive)."""
    path = src.path
    if len(head) < 2:
        raise BVHError(f"{head[0]}: expected a joint name", path=path, line=head_line)
    name = " ".join(head[1:])
    if len(name) > limits.MAX_NAME:
        raise BVHError(f"joint name {shorten(name)} is {len(name):,} characters long (the limit is "
                       f"{limits.MAX_NAME})", path=path, line=head_line)
    if not name.isprintable():
        raise BVHError(f"joint name {shorten(name)} contains an invisible or control character",
                       path=path, line=head_line)
    if len(scan.names) >= limits.MAX_JOINTS:
        raise BVHError(f"more than {limits.MAX_JOINTS} joints", path=path, line=head_line)
    if depth > limits.MAX_DEPTH:
        raise BVHError(f"joints nested more than {limits.MAX_DEPTH} deep", path=path, line=head_line)
    if name in scan.names:
        first = scan.name_lines[scan.names.index(name)]
        raise BVHError(f"duplicate joint name {shorten(name)} (first defined at line {first})",
                       path=path, line=head_line)
    j = len(scan.names)
    scan.names.append(name)
    scan.name_lines.append(head_line)
    scan.parents.append(parent)
    scan.end_sites.append([math.nan] * 3)
    what = f"joint {shorten(name)}"

    ln, tok = src.next(f"'{{' opening {what}")
    if tok != ["{"]:
        raise BVHError(f"expected '{{' opening {what}, found {_show(tok)}", path=path, line=ln)
    scan.offsets.append(_scan_offset(src, what))

    ln, tok = src.next(f"CHANNELS <n> <names> of {what}")
    if tok[0] != "CHANNELS":
        raise BVHError(f"expected CHANNELS <n> <names> of {what}, found {_show(tok)}", path=path, line=ln)
    if len(tok) < 2 or not (tok[1].isascii() and tok[1].isdigit() and len(tok[1]) <= 3):
        raise BVHError(f"CHANNELS of {what}: expected a channel count (0 to 6), found {_show(tok[1:2])}",
                       path=path, line=ln)
    n = int(tok[1])
    if len(tok) - 2 != n:
        raise BVHError(f"CHANNELS of {what}: the count says {n} but {len(tok) - 2} names follow",
                       path=path, line=ln)
    chans = []
    for c in tok[2:]:
        norm = CHANNEL_NAMES.get(c.lower())
        if norm is None:
            raise BVHError(f"CHANNELS of {what}: unknown channel {shorten(c)}, expected one of "
                           + ", ".join(CHANNEL_NAMES.values()), path=path, line=ln)
        if norm in chans:
            raise BVHError(f"CHANNELS of {what}: channel {norm} appears twice", path=path, line=ln)
        chans.append(norm)
    scan.channels.append(tuple(chans))

    while True:
        ln, tok = src.next(f"JOINT, End Site or '}}' closing {what} (opened at line {head_line})")
        if tok[0] == "JOINT":
            _scan_joint(src, scan, tok, ln, parent=j, depth=depth + 1)
        elif tok == ["End", "Site"]:
            if not math.isnan(scan.end_sites[j][0]):
                raise BVHError(f"{what} has a second End Site", path=path, line=ln)
            ln2, tok2 = src.next(f"'{{' opening the End Site of {what}")
            if tok2 != ["{"]:
                raise BVHError(f"expected '{{' opening the End Site of {what}, found {_show(tok2)}",
                               path=path, line=ln2)
            scan.end_sites[j] = _scan_offset(src, f"the End Site of {what}")
            ln2, tok2 = src.next(f"'}}' closing the End Site of {what}")
            if tok2 != ["}"]:
                raise BVHError(f"expected '}}' closing the End Site of {what} (opened at line {ln}), "
                               f"found {_show(tok2)}", path=path, line=ln2)
        elif tok == ["}"]:
            return
        else:
            raise BVHError(f"expected JOINT, End Site or '}}' closing {what} (opened at line {head_line}), "
                           f"found {_show(tok)}", path=path, line=ln)


def load_bvhio():
    """bvhio, imported on first use (about 0.1 s, mostly PyGLM).

    PyGLM >= 2.8 warns (PendingDeprecationWarning) about bvhio's ``import glm``; that is
    bvhio's business, not the user's, so the warning is silenced for that import only.
    """
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message=".*import glm.*", category=PendingDeprecationWarning)
        import bvhio
    return bvhio


def cross_check_with_bvhio(path: str, scan: Scan) -> None:
    """Parse the hierarchy with bvhio (the parser of record) and compare it with the scan.

    Only called after the scan accepted the whole header, so bvhio cannot run into the end
    of the file (where its ``parseLine`` would loop forever).
    """
    try:
        bvh = load_bvhio().readAsBvh(path, loadKeyFrames=False)
    except Exception:
        # bvhio is stricter than the BVH files in the wild in two ways the scan accepts:
        # joint names containing spaces (it keeps the first word and then fails or
        # mis-names) and files not in the locale's encoding.  The scan, which has checked
        # every line, is used alone for such a file.
        return
    layout = [entry[0] for entry in bvh.Root.layout()]
    problems = []
    if [j.Name for j in layout] != [n.split()[0] for n in scan.names]:
        problems.append("joint names differ")
    else:
        for k, j in enumerate(layout):
            name = scan.names[k]
            if tuple(CHANNEL_NAMES.get(c.lower(), c) for c in j.Channels) != scan.channels[k]:
                problems.append(f"channels of joint {name!r} differ")
            off = np.array([j.Offset.x, j.Offset.y, j.Offset.z], dtype=np.float64)
            if not np.allclose(off, scan.offsets[k], rtol=1e-6, atol=1e-6):
                problems.append(f"offset of joint {name!r} differs")
            es = np.array(scan.end_sites[k])
            if not np.isnan(es[0]):
                bes = np.array([j.EndSite.x, j.EndSite.y, j.EndSite.z], dtype=np.float64)
                if not np.allclose(bes, es, rtol=1e-6, atol=1e-6):
                    problems.append(f"End Site of joint {name!r} differs")
            parent = scan.parents[k]
            if parent >= 0 and j not in layout[parent].Children:
                problems.append(f"parent of joint {name!r} differs")
        if bvh.FrameCount != scan.frames:
            problems.append("Frames: differs")
        if not math.isclose(bvh.FrameTime, scan.frame_time, rel_tol=1e-12):
            problems.append("Frame Time differs")
    if problems:
        raise BVHError("bvhio and the line scanner disagree on the hierarchy ("
                       + "; ".join(problems[:3]) + "); please report this file", path=path)


