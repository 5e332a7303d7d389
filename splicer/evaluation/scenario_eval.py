"""Scoring the splice and the baselines on the scenarios of :mod:`splicer.scenarios` (issue 8).

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

import time
from pathlib import Path

import numpy as np
import pandas as pd

from .baselines import generic_dtw_frames, oracle_frames, uniform_frames
from ..errors import SplicerError
from ..model.motion import Motion
from ..model.rotations import quat_angle_deg
from .scenarios import SCENARIOS, ScenarioSeparation, alignment_error_s, make_scenario, scenario, write_scenario
from .separate import protocol_joints
from ..pipeline import splice
from ..transfer.sampling import sample_rotations

__all__ = ["SCENARIO_METHODS", "SCENARIO_METRICS", "ranges_mask", "report_flags", "flag_scores",
           "uncovered_scores", "alignment_scores", "pause_scores", "confidence_auc", "judged_error",
           "evaluate_scenario_pair", "evaluate_scenarios",
           "summarize_scenarios", "scenario_markdown"]

#: splice options of each splice-based method (the current defaults: open ends)
SPLICE = {
    "splice (smooth time map)": {"merge": "timemap"},
    "splice (median merge)": {"merge": "median"},
}
SCENARIO_METHODS = ("oracle", "uniform scaling", "generic DTW", "generic DTW, open ends") + tuple(SPLICE)

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


def evaluate_scenario_pair(take: Motion, sep: ScenarioSeparation, *, methods=SCENARIO_METHODS,
                           splice_options: dict | None = None, generic_window: int | None = None) -> list[dict]:
    """Run and score every method on one scenario separation of ``take``.

    Returns
    -------
    list of dict
        One record per method: ``method`` and the keys of :data:`SCENARIO_METRICS`.
    """
    unknown = [m for m in methods if m not in SCENARIO_METHODS]
    if unknown:
        raise SplicerError(f"unknown method(s) {unknown}; choose from {list(SCENARIO_METHODS)}")
    roles, moving = protocol_joints(take)
    ref = sample_rotations(take.rotations[:, moving], sep.body_time)
    body, hands = sep.body, sep.hands
    n, fb = body.n_frames, body.fps
    covered = sep.covered
    side_joints = {s: [k for k, j in enumerate(moving) if j in arm.finger_joints] for s, arm in roles.sides.items()}
    side_joints = {s: ks for s, ks in side_joints.items() if ks}
    ident = np.zeros((n, 4))
    ident[:, 0] = 1.0
    records = []
    for method in methods:
        t0 = time.perf_counter()
        frames, flags = {}, {}
        if method in SPLICE:
            res = splice(body, hands, **{**(splice_options or {}), **SPLICE[method]})
            q = res.motion.rotations[:, moving]
            for s in side_joints:
                if s in res.sides:
                    frames[s] = np.asarray(res.sides[s].hands_frame, dtype=np.float64)
                    flags[s] = report_flags(res.report["sides"][s], n)
        else:
            for s in side_joints:
                if method == "oracle":
                    frames[s] = oracle_frames(sep.truth)
                elif method == "uniform scaling":
                    frames[s] = uniform_frames(n, hands.n_frames)
                else:
                    frames[s] = generic_dtw_frames(body, hands, roles.sides[s], roles.sides[s], roles.up,
                                                   window=generic_window, open_ends=method.endswith("open ends"))
            q = np.array(ref)
            for s, ks in side_joints.items():
                hf = frames[s]
                ok = np.isfinite(hf)
                sampled = sample_rotations(hands.rotations[:, [moving[k] for k in ks]], np.where(ok, hf, 0.0))
                q[:, ks] = np.where(ok[:, None, None], sampled, ident[:, None, :])
        t_total = time.perf_counter() - t0
        errs, covs, uncs, lows, confs, has_unc, has_low = [], [], [], [], [], False, False
        for s, hf in frames.items():
            unc, low = flags.get(s, (None, None))
            e = alignment_error_s(sep, hf)
            if unc is not None:
                e = np.where(unc, np.nan, e)  # reported uncovered: no hands frame
                has_unc = True
            has_low |= low is not None
            errs.append(e)
            conf = res.report["sides"][s].get("confidence") if method in SPLICE else None
            confs.append(np.asarray(conf, dtype=np.float64) if conf is not None and len(conf) == n else None)
            covs.append(covered)
            uncs.append(unc if unc is not None else np.zeros(n, bool))
            lows.append(low if low is not None else np.zeros(n, bool))
        err = np.concatenate(errs) if errs else np.full(n, np.nan)
        cov = np.concatenate(covs) if covs else covered
        unc_all = np.concatenate(uncs) if has_unc else None
        low_all = np.concatenate(lows) if has_low else None
        rec = {"method": method, **alignment_scores(err, cov, fb), **pause_scores(err, sep, len(errs))}
        rec["finger_deg"] = float(np.mean(quat_angle_deg(q[covered], ref[covered]))) if covered.any() else np.nan
        rec["covered"] = 100.0 * float(covered.mean())
        rec.update(uncovered_scores(cov, unc_all))
        fl = flag_scores(err, cov, unc_all, low_all)
        rec.update(flag_bad=fl["flag_bad"], flag_good=fl["flag_good"])
        if confs and all(c is not None for c in confs):
            rec["conf_auc"] = confidence_auc(np.concatenate(confs), judged_error(err, cov, unc_all))
        else:
            rec["conf_auc"] = np.nan
        rec["t_total"] = t_total
        records.append(rec)
    return records


def _take_name(take: Motion) -> str:
    return Path(take.source).name if take.source and not take.source.startswith("synth") else "synthetic"


def evaluate_scenarios(takes, scenarios=SCENARIOS, *, seeds=range(100, 105), methods=SCENARIO_METHODS,
                       splice_options: dict | None = None, generic_window: int | None = None,
                       progress=None, dump=None, **separation) -> pd.DataFrame:
    """Every take x scenario x seed x method, scored.

    Parameters
    ----------
    takes : sequence of Motion
    scenarios : sequence of str
        Names for :func:`splicer.scenarios.scenario`.
    seeds : iterable of int
    dump : path, optional
        Also write each separation to ``dump/<take>/<scenario>/seed<N>/`` (:func:`splicer.scenarios.write_scenario`).
    separation
        Passed to :func:`splicer.scenarios.make_scenario` (``amplitude``, ``yaw_deg``, ...).

    Returns
    -------
    pd.DataFrame
        One row per run: ``take``, ``scenario``, ``seed``, ``method`` and :data:`SCENARIO_METRICS`.
    """
    rows = []
    seeds = list(seeds)
    if not seeds:
        raise SplicerError("need at least one seed")
    for name in scenarios:
        sc = scenario(name)
        for take in takes:
            tname = _take_name(take)
            for seed in seeds:
                t0 = time.perf_counter()
                sep = make_scenario(take, sc, rng=np.random.default_rng(seed), **separation)
                if dump is not None:
                    write_scenario(sep, Path(dump) / Path(tname).stem / sc.name / f"seed{seed}")
                recs = evaluate_scenario_pair(take, sep, methods=methods, splice_options=splice_options,
                                              generic_window=generic_window)
                for r in recs:
                    rows.append({"take": tname, "scenario": sc.name, "seed": seed, **r})
                if progress is not None:
                    main = {r["method"]: r for r in recs}.get("splice (smooth time map)")
                    extra = (f": splice {main['align_mean_s']:.3f} s mean, {main['align_p95_s']:.3f} s p95, "
                             f"{main['finger_deg']:.2f} deg") if main else ""
                    progress(f"{sc.name} / {tname} / seed {seed}{extra} ({time.perf_counter() - t0:.1f} s)")
    return pd.DataFrame(rows)


def summarize_scenarios(runs: pd.DataFrame) -> pd.DataFrame:
    """(scenario, method) x metric: mean over runs and, beside it, the worst run."""
    order_m = [m for m in SCENARIO_METHODS if m in set(runs["method"])]
    order_s = list(dict.fromkeys(runs["scenario"]))
    runs = runs.assign(**{k: np.nan for k in SCENARIO_METRICS if k not in runs.columns})  # older runs files
    g = runs.groupby(["scenario", "method"], sort=False)
    cols = {}
    for key, (label, worst) in SCENARIO_METRICS.items():
        cols[label] = g[key].mean()
        cols[f"{label} worst"] = g[key].max() if worst == "max" else g[key].min()
    table = pd.DataFrame(cols)
    idx = pd.MultiIndex.from_tuples([(s, m) for s in order_s for m in order_m if (s, m) in table.index],
                                    names=["scenario", "method"])
    return table.reindex(idx)


#: compact table: heading -> (metric label, digits)
COMPACT = {
    "align mean, s (frames)": ("align mean (s)", 3),
    "align p95, s": ("align p95 (s)", 3),
    "within 0.05 s, %": ("within 0.05 s (%)", 1),
    "pause window mean, s": ("pause window mean (s)", 3),
    "finger, deg": ("finger error (deg)", 2),
    "uncovered found, %": ("uncovered found (%)", 1),
    "err > 0.1 s flagged, %": ("err > 0.1 s flagged (%)", 1),
    "err < 0.05 s flagged, %": ("err < 0.05 s flagged (%)", 1),
    "confidence AUC": ("confidence AUC", 2),
}


def scenario_markdown(table: pd.DataFrame, scenario_name: str) -> str:
    """One scenario's compact table: ``mean (worst run)`` cells; frames beside the seconds."""
    sub = table.xs(scenario_name, level="scenario")
    lines = ["| method | " + " | ".join(COMPACT) + " |", "|---|" + "---:|" * len(COMPACT)]
    for method, row in sub.iterrows():
        cells = []
        for head, (label, d) in COMPACT.items():
            m, w = row[label], row[f"{label} worst"]
            if pd.isna(m):
                cells.append("—")
            elif head.startswith("align mean"):
                f, fw = row["align mean (frames)"], row["align mean (frames) worst"]
                cells.append(f"{m:.{d}f} ({w:.{d}f}) = {f:.1f} ({fw:.1f}) fr")
            else:
                cells.append(f"{m:.{d}f} ({w:.{d}f})")
        lines.append(f"| {method} | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def overview_markdown(runs: pd.DataFrame, method: str = "splice (smooth time map)") -> str:
    """One line per (scenario, take) for ``method``: mean and p95 error (s), finger error, and the
    generic DTW's finger error beside it."""
    lines = ["| scenario | take | align mean, s | align p95, s | finger, deg | generic DTW finger, deg "
             "| oracle finger, deg |",
             "|---|---|---:|---:|---:|---:|---:|"]
    for (sc, take), grp in runs.groupby(["scenario", "take"], sort=False):
        by = grp.groupby("method")
        if method not in by.groups:
            continue
        mm = by.get_group(method)
        gd = by.get_group("generic DTW")["finger_deg"].mean() if "generic DTW" in by.groups else np.nan
        orc = by.get_group("oracle")["finger_deg"].mean() if "oracle" in by.groups else np.nan
        lines.append(f"| {sc} | {take} | {mm['align_mean_s'].mean():.3f} (max {mm['align_mean_s'].max():.3f}) | "
                     f"{mm['align_p95_s'].mean():.3f} (max {mm['align_p95_s'].max():.3f}) | "
                     f"{mm['finger_deg'].mean():.2f} | {gd:.2f} | {orc:.2f} |")
    return "\n".join(lines) + "\n"


def scenario_cli(args, params, err) -> int:
    """``splicer-evaluate --scenario NAME`` / ``--scenarios all`` (called by :func:`splicer.evaluate.main`)."""
    from .evaluate import default_takes
    from .synth import make_gesture_take

    import yaml

    opts = {}
    for kv in args.splice_option or []:
        key, sep_, val = kv.partition("=")
        if not sep_ or not key:
            err(f"splicer-evaluate: --splice-option needs KEY=VALUE, got {kv!r}")
            return 1
        opts[key.strip()] = yaml.safe_load(val)
    names = list(SCENARIOS) if args.scenarios == "all" else []
    names += [n for n in (args.scenario or []) if n not in names]
    try:
        for nm in names:
            scenario(nm)
        if args.runs_csv:
            missing = [f for f in args.runs_csv if not Path(f).is_file()]
            if missing:
                raise SplicerError(f"{missing[0]}: no such file")
            runs = pd.concat([pd.read_csv(f) for f in args.runs_csv], ignore_index=True)
            if names:
                runs = runs[runs["scenario"].isin([scenario(nm).name for nm in names])]
            takes_txt = ", ".join(dict.fromkeys(runs["take"])) + f" (runs read from {', '.join(args.runs_csv)})"
        else:
            takes = default_takes(args.bvh, synthetic_seconds=args.synthetic_seconds,
                                  note=lambda m: (print(m), err(m)))
            if args.synthetic and not all(t.source and t.source.startswith("synth") for t in takes):
                takes.append(make_gesture_take(args.synthetic_seconds, 30.0, np.random.default_rng(0)))
            runs = evaluate_scenarios(takes, names, seeds=range(args.seed0, args.seed0 + args.seeds),
                                      splice_options=opts or None, generic_window=args.generic_window,
                                      progress=err, dump=args.dump, amplitude=params.amplitude,
                                      yaw_deg=params.yaw_deg, noise_deg=params.noise_deg,
                                      warp_sigma_s=params.warp_sigma_s)
            takes_txt = ", ".join(f"{_take_name(t)} ({t.n_frames} frames @ {t.fps:g} fps)" for t in takes)
    except (SplicerError, ValueError, TypeError) as e:
        err(f"splicer-evaluate: {e}")
        return 1
    if runs.empty:
        err("splicer-evaluate: no runs to tabulate")
        return 1
    table = summarize_scenarios(runs)
    seeds = sorted(set(runs["seed"]))
    shown = opts or ("as recorded" if args.runs_csv else "defaults")
    header = (f"Takes: {takes_txt}. Seeds {seeds[0]}..{seeds[-1]}. Splice options: {shown}. "
              "Cells: mean over runs (worst run). "
              "Alignment error in seconds of the performance (frames = seconds x body fps) over body frames "
              "the hands cover; finger error in degrees over covered frames.\n")
    parts = [header]
    for nm in dict.fromkeys(runs["scenario"]):
        parts.append(f"\n### {nm}\n\n" + scenario_markdown(table, nm))
    parts.append("\n### splice (smooth time map), per scenario and take\n\n" + overview_markdown(runs))
    text = "".join(parts)
    print(text)
    if args.out:
        out = Path(args.out)
        out.parent.mkdir(parents=True, exist_ok=True)
        table.round(5).to_csv(out.with_suffix(".csv"))
        runs.round(5).to_csv(out.parent / (out.name + "_runs.csv"), index=False)
        out.with_suffix(".md").write_text("# Scenarios (splicer-evaluate --scenario)\n\n" + text, encoding="utf-8")
        err(f"wrote {out.with_suffix('.csv')}, {out.name}_runs.csv and {out.with_suffix('.md')}")
    return 0
