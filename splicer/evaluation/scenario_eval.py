"""Scoring the splice and the baselines on the scenarios of :mod:`splicer.scenarios` (issue 8).

Per run (take x scenario x seed x method), over both sides' body frames, the scores of
:mod:`splicer.evaluation.scenario_scores` (alignment error, pause windows, missing frames, finger
error, uncovered detection, confidence honesty and ranking); then the summary tables and the
``splicer-evaluate --scenarios`` command.

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
from .scenario_scores import (SCENARIO_METRICS, alignment_scores, confidence_auc, flag_scores,  # noqa: F401
                              judged_error, pause_scores, ranges_mask, report_flags, uncovered_scores)
from .separate import protocol_joints
from ..pipeline import splice
from ..transfer.sampling import sample_rotations

__all__ = ["SCENARIO_METHODS", "SCENARIO_METRICS", "ranges_mask", "report_flags", "flag_scores",
           "uncovered_scores", "alignment_scores", "pause_scores", "confidence_auc", "judged_error",
           "evaluate_scenario_pair", "evaluate_scenarios", "CLEAN_SCENARIOS", "flags_by_frames", "flags_markdown",
           "summarize_scenarios", "scenario_markdown"]

#: splice options of each splice-based method (the current defaults: open ends)
SPLICE = {
    "splice (smooth time map)": {"merge": "timemap"},
    "splice (median merge)": {"merge": "median"},
}
SCENARIO_METHODS = ("oracle", "uniform scaling", "generic DTW", "generic DTW, open ends") + tuple(SPLICE)


def evaluate_scenario_pair(take: Motion, sep: ScenarioSeparation, *, methods=SCENARIO_METHODS,
                           splice_options: dict | None = None, generic_window: int | None = None) -> list[dict]:
    """Run and score every method on one scenario separation of ``take``.

    Returns
    -------
    list of dict
        One record per method: ``method``, the keys of :data:`SCENARIO_METRICS`, and ``n_bad`` /
        ``n_good``, the counts of judged frames behind ``flag_bad`` / ``flag_good`` (both sides:
        what weighs the runs' flags by their frames, :func:`flags_by_frames`).
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
        rec.update(flag_bad=fl["flag_bad"], flag_good=fl["flag_good"], n_bad=fl["n_bad"], n_good=fl["n_good"])
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


#: The scenarios without a second performance (README *Confidence honesty*: "the seven").
CLEAN_SCENARIOS = ("base", "extra", "short", "pause-hands", "pause-body", "speed", "rate")


def flags_by_frames(runs: pd.DataFrame, method: str = "splice (smooth time map)", scenarios=None) -> pd.DataFrame:
    """Confidence honesty per take: the flags' mean over runs, and weighted by each run's frames.

    Parameters
    ----------
    runs : pd.DataFrame
        Rows of :func:`evaluate_scenarios` (with ``n_bad`` and ``n_good``).
    method : str
    scenarios : iterable of str, optional
        Only these (e.g. :data:`CLEAN_SCENARIOS`); None: every scenario in ``runs``.

    Returns
    -------
    pd.DataFrame
        Indexed by take: ``flag_bad`` / ``flag_good`` (mean over the runs that have such frames,
        %), ``flag_bad_frames`` / ``flag_good_frames`` (each run's share times its count of such
        frames, over the counts: the share of all those frames that is flagged, %), ``runs``.

    Examples
    --------
    >>> runs = pd.DataFrame({"take": ["t", "t"], "scenario": ["base", "all"], "method": ["m", "m"],
    ...                      "flag_bad": [100.0, 50.0], "n_bad": [1, 9], "flag_good": [0.0, 10.0], "n_good": [90, 10]})
    >>> flags_by_frames(runs, "m").round(1).to_dict("records")
    [{'flag_bad': 75.0, 'flag_good': 5.0, 'flag_bad_frames': 55.0, 'flag_good_frames': 1.0, 'runs': 2}]
    """
    r = runs[runs["method"] == method]
    if scenarios is not None:
        r = r[r["scenario"].isin(list(scenarios))]
    rows = {}
    for take, g in r.groupby("take", sort=False):
        row = {"flag_bad": g["flag_bad"].mean(), "flag_good": g["flag_good"].mean()}
        for k in ("bad", "good"):
            n = g[f"n_{k}"].fillna(0.0) if f"n_{k}" in g else pd.Series(np.nan, index=g.index)
            share = g[f"flag_{k}"].fillna(0.0)
            row[f"flag_{k}_frames"] = float((share * n).sum() / n.sum()) if n.sum() > 0 else np.nan
        row["runs"] = len(g)
        rows[take] = row
    return pd.DataFrame.from_dict(rows, orient="index")


def flags_markdown(runs: pd.DataFrame, method: str = "splice (smooth time map)") -> str:
    """The lines of :func:`flags_by_frames` over :data:`CLEAN_SCENARIOS` and over every scenario."""
    lines = ["| scenarios | take | err > 0.1 s flagged, % (runs; frames) | err < 0.05 s flagged, % (runs; frames) |",
             "|---|---|---:|---:|"]
    for label, which in (("the seven without a second performance", CLEAN_SCENARIOS), ("all in these runs", None)):
        t = flags_by_frames(runs, method, which)
        for take, row in t.iterrows():
            lines.append(f"| {label} | {take} | {row.flag_bad:.1f}; {row.flag_bad_frames:.1f} | "
                         f"{row.flag_good:.1f}; {row.flag_good_frames:.1f} |")
    return "\n".join(lines) + "\n"


def scenario_cli(args, params, err) -> int:
    """``splicer-evaluate --scenario NAME`` / ``--scenarios all`` (called by :func:`splicer.evaluate.main`)."""
    from .evaluate import default_takes, splice_option_args
    from .synth import make_gesture_take

    opts = splice_option_args(args.splice_option, err)
    if opts is None:
        return 1
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
    if {"n_bad", "n_good"} <= set(runs.columns):
        parts.append("\n### splice (smooth time map), confidence honesty\n\n" + flags_markdown(runs))
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
