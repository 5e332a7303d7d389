"""The rows and files of a ``splice-batch`` summary (:mod:`splicer.batch`).

One row per pair (:func:`summary_row`: status, frames, cost, confidence (the lowest side's mean
over covered frames, the shares of frames low confidence and uncovered, the check against the
hands played backwards), seconds, warnings, error, paths), written by :func:`write_summary` as ``summary.csv``, ``summary.md`` and, with
the alignment plots, ``summary.html``.  Every file goes through the package's one atomic
writer.
"""

from __future__ import annotations

import csv
import html
import io
import math
import os
from pathlib import Path

from .io.atomic import write_text_atomic
from .manifest import PairJob

__all__ = ["summary_row", "write_summary"]


def _write_atomic(path: Path, text: str) -> None:
    """``text`` to ``path`` through the package's one atomic writer (a replaced file keeps its
    mode), creating the folder first."""
    path.parent.mkdir(parents=True, exist_ok=True)
    write_text_atomic(path, text)



def _frames_in(ranges) -> int:
    """Frames in a report's ``[first, last]`` ranges."""
    return sum(int(b) - int(a) + 1 for a, b in ranges or [] if isinstance(a, int) and isinstance(b, int))


def _pair_figures(rep: dict) -> dict:
    """A pair's confidence figures from its report, over its sides: the lowest mean confidence over
    covered body frames, the highest share (%) of body frames low confidence and uncovered, the
    highest check against the hands played backwards (None where a report has none)."""
    conf, low, unc, back = [], [], [], []
    for d in (rep.get("sides") or {}).values():
        if not isinstance(d, dict):
            continue
        hf = d.get("hands_frame") or []
        c = d.get("confidence")
        if isinstance(c, list) and len(c) == len(hf):
            vals = [float(x) for x, h in zip(c, hf) if h is not None and isinstance(x, (int, float))]
            if vals:
                conf.append(sum(vals) / len(vals))
        if hf:
            low.append(100.0 * _frames_in(d.get("low_confidence")) / len(hf))
            unc.append(100.0 * _frames_in(d.get("uncovered")) / len(hf))
        r = (d.get("pass1") or {}).get("backwards_ratio")
        if isinstance(r, (int, float)) and not isinstance(r, bool) and math.isfinite(r):
            back.append(float(r))
    return {"confidence": round(min(conf), 3) if conf else None, "low_confidence_pct": round(max(low), 1) if low else None,
            "uncovered_pct": round(max(unc), 1) if unc else None, "backwards_ratio": max(back) if back else None}


def summary_row(job: PairJob, status: str, *, rep: dict | None = None, seconds: float | None = None,
                error: str = "", report: str = "", plot: str = "") -> dict:
    """The summary row of one pair (``rep``: its report, when it has one)."""
    rep = rep or {}
    sides = rep.get("sides") or {}
    costs = [s["pass1"]["cost"] for s in sides.values() if isinstance(s, dict) and s.get("pass1")]
    return {"name": job.name, "status": status, "body": job.body, "hands": job.hands, "output": job.output,
            "body_frames": (rep.get("body") or {}).get("frames"),
            "hands_frames": (rep.get("hands") or {}).get("frames"),
            "sides": ",".join(sides), "pass1_cost": round(sum(costs), 3) if costs else None,
            **_pair_figures(rep), "seconds": round(seconds, 2) if seconds is not None else None,
            "warnings": list(rep.get("warnings") or []), "error": error, "report": report, "plot": plot}


_COLUMNS = ["name", "status", "body_frames", "hands_frames", "sides", "pass1_cost", "confidence", "low_confidence_pct",
            "uncovered_pct", "backwards_ratio", "seconds", "warnings", "error", "body", "hands", "output", "report"]


def _cell(v) -> str:
    if v is None:
        return ""
    if isinstance(v, list):
        return " | ".join(v)
    if isinstance(v, float):
        return f"{v:.4g}"
    return str(v)


def write_summary(rows: list[dict], out_dir, *, html_page: bool = False) -> None:
    """``summary.csv``, ``summary.md`` (and ``summary.html`` with plots) in ``out_dir``."""
    out = Path(out_dir)
    buf = io.StringIO()
    w = csv.writer(buf)
    w.writerow(_COLUMNS)
    for r in rows:
        w.writerow([_cell(r.get(c)) for c in _COLUMNS])
    _write_atomic(out / "summary.csv", buf.getvalue())

    counts = {}
    for r in rows:
        counts[r["status"]] = counts.get(r["status"], 0) + 1
    md = [f"# Batch summary: {len(rows)} pairs (" + ", ".join(f"{v} {k}" for k, v in sorted(counts.items())) + ")", "",
          "| pair | status | body frames | hands frames | sides | confidence | low confidence, % | uncovered, % "
          "| cost vs hands played backwards | seconds | warnings |",
          "|---|---|---:|---:|---|---:|---:|---:|---:|---:|---|"]
    for r in rows:
        warn = r["error"] or ("; ".join(r["warnings"]) if r["warnings"] else "")
        md.append(f"| {r['name']} | {r['status']} | {_cell(r['body_frames'])} | {_cell(r['hands_frames'])} | "
                  f"{r['sides']} | {_cell(r.get('confidence'))} | {_cell(r.get('low_confidence_pct'))} | "
                  f"{_cell(r.get('uncovered_pct'))} | {_cell(r.get('backwards_ratio'))} | {_cell(r['seconds'])} | "
                  f"{warn.replace('|', '/')} |")
    _write_atomic(out / "summary.md", "\n".join(md) + "\n")
    if not html_page:
        return
    e = html.escape
    parts = ["<!doctype html><html><head><meta charset='utf-8'><title>splice-batch summary</title>",
             "<style>body{font-family:sans-serif}table{border-collapse:collapse}td,th{border:1px solid #ccc;"
             "padding:3px 6px;vertical-align:top}.failed,.refused{background:#fdd}img{max-width:900px}</style>",
             f"</head><body><h1>{e(md[0][2:])}</h1><table><tr><th>pair</th><th>status</th><th>frames (body/hands)</th>"
             "<th>confidence</th><th>low confidence, %</th><th>uncovered, %</th><th>cost vs hands played backwards</th>"
             "<th>seconds</th><th>warnings</th></tr>"]
    for r in rows:
        warn = [r["error"]] if r["error"] else r["warnings"]
        parts.append(f"<tr class='{e(r['status'].split()[0])}'><td><a href='#{e(r['name'])}'>{e(r['name'])}</a></td>"
                     f"<td>{e(r['status'])}</td><td>{e(_cell(r['body_frames']))} / {e(_cell(r['hands_frames']))}</td>"
                     f"<td>{e(_cell(r.get('confidence')))}</td><td>{e(_cell(r.get('low_confidence_pct')))}</td>"
                     f"<td>{e(_cell(r.get('uncovered_pct')))}</td><td>{e(_cell(r.get('backwards_ratio')))}</td>"
                     f"<td>{e(_cell(r['seconds']))}</td>"
                     f"<td>{'<br>'.join(e(x) for x in warn)}</td></tr>")
    parts.append("</table>")
    for r in rows:
        if r.get("plot"):
            rel = os.path.relpath(r["plot"], out)
            parts.append(f"<h2 id='{e(r['name'])}'>{e(r['name'])}</h2><p>{e(Path(r['body']).name)} + "
                         f"{e(Path(r['hands']).name)} &rarr; {e(r['output'])}</p>"
                         f"<img src='{e(rel)}' alt='alignment plot'>")
    parts.append("</body></html>")
    _write_atomic(out / "summary.html", "\n".join(parts))
