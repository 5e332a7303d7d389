"""The scores of one scenario run (:mod:`splicer.evaluation.scenario_eval` runs the methods).

Per run (take x scenario x seed x method), over both sides' body frames:

* alignment error (:func:`splicer.scenarios.alignment_error_s`), over the frames the truth
  covers and the method gives a hands frame for: mean, 95th percentile and maximum, in
  seconds and in body frames (seconds x body fps); the share within 0.05 s and 0.1 s;
* pause window: mean and maximum error over the body frames from each pause's start to 3 s
  after its end (the issue saw the time map lag for seconds after a pause);
* ``missing``: share of covered frames the method gives no hands frame for (NaN in its
  ``hands_frame`` or inside its reported ``uncovered`` ranges) — they keep the body's own
  fingers, which the finger error charges;
* finger error, degrees: geodesic angle between the result's local finger rotations and the
  original take's at the body's instants, mean over the moving finger joints and the covered
  frames (the body's own fingers are at identity in this protocol, so uncovered frames are
  not scored here);
* uncovered detection, when the report has ``sides[side]["uncovered"]``: share of the truly
  uncovered body frames inside those ranges (``unc_found``) and share of covered frames
  inside them (``unc_false``);
* confidence honesty, when the report has ``low_confidence`` and/or ``uncovered`` ranges:
  ``flag_bad``, the share of frames whose true error exceeds 0.1 s that lie in a flagged range
  (target >= 80 %), and ``flag_good``, the share of frames whose true error is below 0.05 s
  that do (target <= 15 %).  A truly uncovered frame the method does not report uncovered
  counts as an error above 0.1 s; one it reports uncovered is right and left out; a covered
  frame without a hands frame counts as an error above 0.1 s;
* confidence ranking, when the report has ``sides[side]["confidence"]`` (one number per body
  frame): :func:`confidence_auc`, the probability that a frame with error below 0.05 s is more
  confident than one with error above 0.1 s (same frame classes as the honesty).

Ranges are lists of ``[first, last]`` body frames, inclusive.
"""

from __future__ import annotations

import numpy as np

from .scenario_types import ScenarioSeparation

__all__ = ["SCENARIO_METRICS", "ranges_mask", "report_flags", "judged_error", "flag_scores", "confidence_auc",
           "uncovered_scores", "alignment_scores", "pause_scores"]

#: metric -> (label, which run is the worst)
SCENARIO_METRICS = {
    "align_mean_s": ("align mean (s)", "max"),
    "align_p95_s": ("align p95 (s)", "max"),
    "align_max_s": ("align max (s)", "max"),
    "align_mean_f": ("align mean (frames)", "max"),
    "align_p95_f": ("align p95 (frames)", "max"),
    "within_50ms": ("within 0.05 s (%)", "min"),
    "within_100ms": ("within 0.1 s (%)", "min"),
    "pause_mean_s": ("pause window mean (s)", "max"),
    "pause_max_s": ("pause window max (s)", "max"),
    "missing": ("no hands frame (%)", "max"),
    "finger_deg": ("finger error (deg)", "max"),
    "covered": ("covered by truth (%)", "min"),
    "unc_found": ("uncovered found (%)", "min"),
    "unc_false": ("covered called uncovered (%)", "max"),
    "flag_bad": ("err > 0.1 s flagged (%)", "min"),
    "flag_good": ("err < 0.05 s flagged (%)", "max"),
    "conf_auc": ("confidence AUC", "min"),
    "t_total": ("time (s)", "max"),
}


def ranges_mask(ranges, n: int) -> np.ndarray:
    """Boolean mask (n,) of the frames inside inclusive ``[first, last]`` ranges (clipped to 0..n-1).

    Examples
    --------
    >>> ranges_mask([[1, 2], [4, 9]], 6).astype(int)
    array([0, 1, 1, 0, 1, 1])
    """
    mask = np.zeros(n, dtype=bool)
    for r in ranges or []:
        if len(r) != 2:
            raise ValueError(f"a range is [first, last], got {r!r}")
        a, b = int(r[0]), int(r[1])
        if b < a:
            raise ValueError(f"range {r!r} ends before it starts")
        mask[max(a, 0):min(b, n - 1) + 1] = True
    return mask


def report_flags(side_report: dict, n: int) -> tuple[np.ndarray | None, np.ndarray | None]:
    """``(uncovered, low_confidence)`` masks (n,) from one side of a splice report; None for a
    key the report does not have."""
    unc = ranges_mask(side_report["uncovered"], n) if "uncovered" in side_report else None
    low = ranges_mask(side_report["low_confidence"], n) if "low_confidence" in side_report else None
    return unc, low


def judged_error(err_s: np.ndarray, covered: np.ndarray, uncovered: np.ndarray | None) -> np.ndarray:
    """The error each frame is judged by for honesty: the true error on covered frames (``inf``
    without a hands frame); on truly uncovered frames NaN (left out) when reported uncovered,
    else ``inf``."""
    unc = uncovered if uncovered is not None else np.zeros(len(covered), bool)
    return np.where(covered, np.where(np.isfinite(err_s), err_s, np.inf), np.where(unc, np.nan, np.inf))


def flag_scores(err_s: np.ndarray, covered: np.ndarray, uncovered: np.ndarray | None,
                low: np.ndarray | None, *, bad_s: float = 0.1, good_s: float = 0.05) -> dict:
    """Confidence honesty of one side (or several sides concatenated).

    Parameters
    ----------
    err_s : np.ndarray [shape=(n,)]
        True alignment error, seconds; NaN where the method gave no hands frame or the frame
        is not covered.
    covered : np.ndarray [shape=(n,), dtype=bool]
        Body frames the truth covers.
    uncovered, low : np.ndarray [shape=(n,), dtype=bool] or None
        The method's ``uncovered`` and ``low_confidence`` ranges as masks.

    Returns
    -------
    dict
        ``flag_bad``: % of frames with error > ``bad_s`` lying in a flagged range; ``flag_good``:
        % of frames with error < ``good_s`` lying in one (NaN when there are none such, or
        when the method reports neither key); ``n_bad``, ``n_good``.
    """
    n = len(covered)
    if uncovered is None and low is None:
        return {"flag_bad": np.nan, "flag_good": np.nan, "n_bad": 0, "n_good": 0}
    unc = uncovered if uncovered is not None else np.zeros(n, bool)
    flagged = unc | (low if low is not None else np.zeros(n, bool))
    e = judged_error(err_s, covered, uncovered)
    judged = ~np.isnan(e)
    bad = judged & (e > bad_s)
    good = judged & (e < good_s)
    pct = lambda sel: 100.0 * float(flagged[sel].mean()) if sel.any() else np.nan  # noqa: E731
    return {"flag_bad": pct(bad), "flag_good": pct(good), "n_bad": int(bad.sum()), "n_good": int(good.sum())}


def confidence_auc(confidence: np.ndarray, err_s: np.ndarray, *, bad_s: float = 0.1, good_s: float = 0.05) -> float:
    """Probability that a frame with true error below ``good_s`` has a higher confidence than a
    frame with true error above ``bad_s`` (ties count half): 1 is a perfect ranking, 0.5 chance.

    Parameters
    ----------
    confidence : np.ndarray [shape=(n,)]
        The report's per-frame confidence in [0, 1].
    err_s : np.ndarray [shape=(n,)]
        True error, seconds (``inf`` for a frame that is wrong without an error, NaN to leave out).

    Returns
    -------
    float
        NaN when either group is empty.

    Examples
    --------
    >>> confidence_auc(np.array([0.9, 0.8, 0.2, 0.8]), np.array([0.0, 0.01, 0.5, 0.3]))
    0.875
    """
    c = np.asarray(confidence, dtype=np.float64)
    e = np.asarray(err_s, dtype=np.float64)
    ok = ~np.isnan(e) & np.isfinite(c)
    good, bad = c[ok & (e < good_s)], c[ok & (e > bad_s)]
    if len(good) == 0 or len(bad) == 0:
        return np.nan
    from scipy.stats import rankdata

    r = rankdata(np.concatenate([good, bad]))
    u = r[:len(good)].sum() - len(good) * (len(good) + 1) / 2.0
    return float(u / (len(good) * len(bad)))


def uncovered_scores(covered: np.ndarray, uncovered: np.ndarray | None) -> dict:
    """``unc_found``: % of truly uncovered frames inside the reported ``uncovered`` ranges;
    ``unc_false``: % of covered frames inside them.  NaN where undefined."""
    if uncovered is None:
        return {"unc_found": np.nan, "unc_false": np.nan}
    return {"unc_found": 100.0 * float(uncovered[~covered].mean()) if (~covered).any() else np.nan,
            "unc_false": 100.0 * float(uncovered[covered].mean()) if covered.any() else np.nan}


def alignment_scores(err_s: np.ndarray, covered: np.ndarray, fps: float) -> dict:
    """Mean, 95th percentile and maximum of the finite errors (seconds and frames at ``fps``),
    the shares within 0.05 s and 0.1 s, and the share of covered frames without an error
    (``missing``), all in %."""
    e = err_s[covered & np.isfinite(err_s)]
    n_cov = int(covered.sum())
    if len(e) == 0:
        out = {k: np.nan for k in ("align_mean_s", "align_p95_s", "align_max_s", "within_50ms", "within_100ms")}
    else:
        out = {"align_mean_s": float(e.mean()), "align_p95_s": float(np.percentile(e, 95)),
               "align_max_s": float(e.max()), "within_50ms": 100.0 * float(np.mean(e <= 0.05)),
               "within_100ms": 100.0 * float(np.mean(e <= 0.1))}
    out["align_mean_f"] = out["align_mean_s"] * fps
    out["align_p95_f"] = out["align_p95_s"] * fps
    out["missing"] = 100.0 * (1.0 - len(e) / n_cov) if n_cov else np.nan
    return out


def pause_scores(err_s: np.ndarray, sep: ScenarioSeparation, n_sides: int) -> dict:
    """Mean and maximum finite error (seconds) over the body frames of the pause windows
    (``sep.params["pause_windows"]``), for ``err_s`` holding ``n_sides`` sides one after the
    other; NaN without a pause."""
    n = sep.body.n_frames
    win = np.tile(ranges_mask(sep.params.get("pause_windows", []), n), max(n_sides, 1))
    e = err_s[win & np.isfinite(err_s)]
    if len(e) == 0:
        return {"pause_mean_s": np.nan, "pause_max_s": np.nan}
    return {"pause_mean_s": float(e.mean()), "pause_max_s": float(e.max())}
