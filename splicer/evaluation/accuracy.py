"""The accuracy table of the evaluation protocol (:mod:`splicer.evaluation.evaluate` runs it).

Its methods (:data:`METHODS`, with the splice options of each splice-based one) and metrics
(:data:`METRICS`), the alignment scores of one run against the truth, and the table over
runs (:func:`summarize`: mean and worst run per metric) with its markdown forms and the
acceptance sentences (:func:`checks`).
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from ..align.passes import hold_ends

__all__ = ["SPLICE_METHODS", "METHODS", "METRICS", "summarize", "COMPACT", "compact_markdown", "checks",
           "to_markdown"]

#: Splice options of each splice-based method.
SPLICE_METHODS = {
    "pass 1 alone": {"passes": "pass1"},
    "pass 2 alone (literal D2)": {"passes": "pass2"},
    "pass 1 + literal pass 2": {"passes": "both", "pass2_weight": 0.0},
    "full, median merge": {"passes": "both", "merge": "median"},
    "full, smooth time map": {"passes": "both", "merge": "timemap"},
    "full, fixed ends": {"passes": "both", "merge": "timemap", "ends": "fixed"},
}
METHODS = ("oracle", "no alignment", "uniform scaling", "generic DTW") + tuple(SPLICE_METHODS)

#: metric -> (column label, which run is the worst: "max" or "min")
METRICS = {
    "align_mean": ("align mean (frames)", "max"),
    "align_max": ("align max (frames)", "max"),
    "within_1": ("within 1 frame (%)", "min"),
    "within_3": ("within 3 frames (%)", "min"),
    "uncovered": ("uncovered (%)", "max"),
    "finger_deg": ("finger error (deg)", "max"),
    "t_markers": ("markers (s)", "max"),
    "t_align": ("alignment (s)", "max"),
    "t_merge": ("merge (s)", "max"),
    "t_total": ("total (s)", "max"),
}


def _alignment_scores(hands_frames: dict, truth: np.ndarray) -> dict:
    """Alignment error (body frames) of each side's ``hands_frames`` against ``truth`` (finite
    everywhere): frames the method leaves uncovered (NaN) are scored with the nearest covered
    value (:func:`splicer.align.hold_ends`), or as infinitely wrong when none is covered."""
    n = len(truth)
    idx = np.arange(n, dtype=np.float64)
    errs, unc = [], []
    for hf in hands_frames.values():
        hf = np.asarray(hf, dtype=np.float64)
        missing = ~np.isfinite(hf)
        unc.append(missing)
        if missing.all():
            errs.append(np.full(n, np.inf))
            continue
        errs.append(np.abs(np.interp(hold_ends(hf) if missing.any() else hf, truth, idx) - idx))
    err = np.concatenate(errs)
    return {"align_mean": float(err.mean()), "align_max": float(err.max()),
            "within_1": 100.0 * float(np.mean(err <= 1.0)), "within_3": 100.0 * float(np.mean(err <= 3.0)),
            "uncovered": 100.0 * float(np.concatenate(unc).mean())}


def _no_alignment_scores() -> dict:
    return {"align_mean": np.nan, "align_max": np.nan, "within_1": np.nan, "within_3": np.nan, "uncovered": np.nan}



def summarize(runs: pd.DataFrame) -> pd.DataFrame:
    """Method x metric table: each metric's mean over runs and, beside it, the worst run.

    Parameters
    ----------
    runs : pd.DataFrame
        From :func:`evaluate`.

    Returns
    -------
    pd.DataFrame
        Index: method (in :data:`METHODS` order); columns ``<label>`` and ``<label> worst`` per metric.
    """
    order = [m for m in METHODS if m in set(runs["method"])]
    g = runs.groupby("method", sort=False)
    cols = {}
    for key, (label, worst) in METRICS.items():
        cols[label] = g[key].mean()
        cols[f"{label} worst"] = g[key].max() if worst == "max" else g[key].min()
    table = pd.DataFrame(cols).reindex(order)
    table.index.name = "method"
    return table


COMPACT = {  # README table: label -> (mean column, worst column)
    "alignment error, frames": ("align mean (frames)", "align mean (frames) worst"),
    "within 1 frame, %": ("within 1 frame (%)", "within 1 frame (%) worst"),
    "within 3 frames, %": ("within 3 frames (%)", "within 3 frames (%) worst"),
    "uncovered, %": ("uncovered (%)", "uncovered (%) worst"),
    "finger error, deg": ("finger error (deg)", "finger error (deg) worst"),
    "time, s": ("total (s)", "total (s) worst"),
}


def compact_markdown(table: pd.DataFrame) -> str:
    """The summary as ``mean (worst seed)`` cells, one column per metric (the README's table)."""
    lines = ["| method | " + " | ".join(COMPACT) + " |", "|---|" + "---:|" * len(COMPACT)]
    for method, row in table.iterrows():
        cells = []
        for mean_col, worst_col in COMPACT.values():
            m, w = row[mean_col], row[worst_col]
            digits = 1 if "%" in mean_col else 2
            cells.append("—" if pd.isna(m) else f"{m:.{digits}f} ({w:.{digits}f})")
        lines.append(f"| {method} | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def checks(runs: pd.DataFrame, method: str = "full, smooth time map") -> list[str]:
    """The acceptance checks of the evaluation issue, per seed, as sentences (true or not)."""
    out = []
    by = runs.pivot_table(index=["take", "seed"], columns="method", values=["align_mean", "finger_deg"])
    for other in ("uniform scaling", "generic DTW"):
        if other in by["align_mean"] and method in by["align_mean"]:
            a = by["align_mean"][method] < by["align_mean"][other]
            f = by["finger_deg"][method] < by["finger_deg"][other]
            out.append(f"{method} beats {other} on alignment in {int(a.sum())}/{len(a)} runs and on finger "
                       f"error in {int(f.sum())}/{len(f)} runs.")
    if "oracle" in by["finger_deg"] and method in by["finger_deg"]:
        gap = (by["finger_deg"][method] - by["finger_deg"]["oracle"]).mean()
        out.append(f"{method}: finger error {gap:.2f} deg above the oracle on average "
                   f"({'within' if gap <= 0.5 else 'NOT within'} the 0.5 deg target).")
    return out


def _fmt(v) -> str:
    if isinstance(v, float) and np.isnan(v):
        return "—"
    if isinstance(v, float):
        return f"{v:.2f}" if abs(v) >= 0.01 or v == 0 else f"{v:.3f}"
    return str(v)


def to_markdown(table: pd.DataFrame) -> str:
    """A GitHub-flavoured markdown table (no extra dependency)."""
    head = [table.index.name or ""] + [str(c) for c in table.columns]
    lines = ["| " + " | ".join(head) + " |", "|" + "|".join(["---"] + ["---:"] * len(table.columns)) + "|"]
    for idx, row in table.iterrows():
        lines.append("| " + " | ".join([str(idx)] + [_fmt(v) for v in row.tolist()]) + " |")
    return "\n".join(lines) + "\n"
