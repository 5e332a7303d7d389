"""The evaluation protocol of ALGORITHM.md section 8, and the ``splicer-evaluate`` command.

From real full-body takes with moving fingers, :func:`splicer.separate.separate` makes
(body, hands, truth) triples; every method aligns the hands to the body and is scored:

* alignment error, body frames: the hands frame a method uses for body frame ``i`` is mapped
  back to body time through the inverse of the truth (``np.interp(hf, truth, arange(n))``)
  and ``i`` subtracted; mean and worst ``|error|`` over both sides' frames, and the share of
  frames within 1 and 3 frames.  A body frame a method leaves uncovered (NaN hands frame, open
  ends) while the truth has a hands frame there is scored with the nearest covered value (the
  time map held at its ends, :func:`splicer.align.hold_ends`), so it counts as the error it
  causes; ``uncovered`` is the share of such frames, in %;
* finger error, degrees: geodesic angle between the result's local finger rotations and the
  original take's, mean over the moving finger joints (:func:`~splicer.separate.moving_finger_joints`)
  and frames; the output is scored as it is (uncovered frames keep the body's own fingers);
* time per stage, seconds (markers, alignment, merge, total; both sides).

Methods: the oracle (hands sampled at the true times), no alignment (fingers flat), uniform
time scaling, a generic DTW (:mod:`splicer.baselines`), and :func:`splicer.splice`
with pass 1 alone, the literal D2 pass alone, pass 1 + the paper's literal pass 2
(``pass2_weight=0``), and the full method with the median merge and with the smooth time map
(all with the default open ends), and the full method with fixed ends (``ends="fixed"``, the
paper's idealised setting: both takes start and end together, as the separation makes them).
Baselines that do not go through ``splice`` sample the hands' finger rotations at their
frames by slerp, as the splice's time-map merge does.

The table has one row per method; each metric is the mean over runs (take x seed) with the
worst run beside it (:mod:`splicer.evaluation.accuracy`: the methods, the metrics and the table).
"""

from __future__ import annotations

import argparse
import sys
import time
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np
import pandas as pd

# the methods, metrics and table are re-exported: they were defined here before the split
from .accuracy import (COMPACT, METHODS, METRICS, SPLICE_METHODS, _alignment_scores, _fmt,  # noqa: F401
                       _no_alignment_scores, checks, compact_markdown, summarize, to_markdown)
from .baselines import flat_rotations, generic_dtw_frames, oracle_frames, uniform_frames
from ..errors import SplicerError
from ..model.motion import Motion
from ..rig.roles import find_roles
from ..model.rotations import quat_angle_deg
from .separate import hand_only_files, mirror_motion, protocol_joints, separate
from ..pipeline import splice
from ..transfer.sampling import sample_rotations

__all__ = ["SeparationParams", "METHODS", "METRICS", "evaluate_pair", "evaluate", "summarize",
           "to_markdown", "default_takes", "main"]

#: Where the real takes live, relative to the repository (never copied into it).
SHARED_ZEGGS = Path(__file__).resolve().parents[3] / "shared" / "motions" / "zeggs"  # ../shared beside the repo


@dataclass(frozen=True)
class SeparationParams:
    """Options of :func:`splicer.separate.separate`, with the values of ALGORITHM.md section 8.

    ``rate_ratio`` is hands frames per second over body frames per second; the others are
    passed through (speeds are ratios, ``amplitude`` a pull factor, ``yaw_deg`` and
    ``noise_deg`` degrees, ``warp_sigma_s`` seconds).
    """

    rate_ratio: float = 2.0
    warp_speed: tuple[float, float] = (0.5, 2.0)
    amplitude: tuple[float, float] = (0.25, 0.7)
    yaw_deg: tuple[float, float] = (25.0, 60.0)
    noise_deg: float = 0.5
    warp_sigma_s: float = 1.5



# --- hands forms (issue 9, c-handonly): the hands capture as a full skeleton, or as the
# hand-only files real captures give (one per side), optionally mirrored like ManipNet's ---
HANDS_FORMS = ("full", "forearm", "wrist")


def hands_inputs(sep, roles, hands_form: str = "full", mirror: bool = False) -> dict:
    """The hands file(s) a method aligns: ``{"both": full take}`` or ``{side: hand-only file}``.

    ``hands_form``: ``"full"`` (the separated full skeleton), ``"forearm"`` (Leap-like: forearm
    root at the wrist) or ``"wrist"`` (ManipNet-like: wrist root); ``mirror``: reflected through
    the X = 0 plane (:func:`splicer.separate.mirror_motion`), names kept.
    """
    if hands_form not in HANDS_FORMS:
        raise SplicerError(f"hands form must be one of {', '.join(HANDS_FORMS)}, not {hands_form!r}")
    files = {"both": sep.hands} if hands_form == "full" else hand_only_files(sep.hands, roles, hands_form)
    if mirror:
        files = {k: mirror_motion(v, 0) for k, v in files.items()}
    return files
# --- end hands forms ---


def evaluate_pair(take: Motion, sep, *, methods=METHODS, generic_window: int | None = None,
                  splice_options: dict | None = None, hands_form: str = "full", mirror: bool = False) -> list[dict]:
    """Run and score every method on one separated take.

    Parameters
    ----------
    take : Motion
        The original take (the reference for the finger error).
    sep : Separation
        From :func:`splicer.separate.separate` applied to ``take``.
    methods : sequence of str
        Names from :data:`METHODS`.
    generic_window : int, optional
        Sakoe-Chiba window of the generic DTW, body frames; full DTW when None.
    splice_options : dict, optional
        Extra :class:`~splicer.options.SpliceOptions` fields applied to every splice method.
    hands_form, mirror
        The form of the hands capture the methods see (see :func:`hands_inputs`); the oracle,
        uniform scaling and the finger reference do not depend on it.

    Returns
    -------
    list of dict
        One record per method: ``method`` and the keys of :data:`METRICS`.
    """
    unknown = [m for m in methods if m not in METHODS]
    if unknown:
        raise SplicerError(f"unknown method(s) {unknown}; choose from {list(METHODS)}")
    roles, moving = protocol_joints(take)
    ref = take.rotations[:, moving]
    n = take.n_frames
    body, hands, truth = sep.body, sep.hands, sep.truth
    inputs = hands_inputs(sep, roles, hands_form, mirror)
    for mo in (body, hands, *inputs.values()):  # Euler -> quaternion conversion (cached) is not charged
        mo.rotations
    side_joints = {s: [k for k, j in enumerate(moving) if j in arm.finger_joints] for s, arm in roles.sides.items()}
    side_joints = {s: ks for s, ks in side_joints.items() if ks}
    records = []
    for method in methods:
        rec = {"method": method, "t_markers": 0.0, "t_align": 0.0, "t_merge": 0.0}
        t_start = time.perf_counter()
        if method in SPLICE_METHODS:
            q = np.array(ref)
            frames = {}
            for key, h in inputs.items():
                side = {} if key == "both" else {"side": key}
                res = splice(body, h, **{**(splice_options or {}), **SPLICE_METHODS[method], **side})
                for s, r in res.sides.items():
                    frames[s] = r.hands_frame
                    ks = side_joints.get(s, [])
                    q[:, ks] = res.motion.rotations[:, [moving[k] for k in ks]]
                tm = res.report["timings_s"]
                rec.update(t_markers=rec["t_markers"] + tm.get("markers", 0.0),
                           t_align=rec["t_align"] + tm.get("pass1", 0.0) + tm.get("pass2", 0.0),
                           t_merge=rec["t_merge"] + tm.get("merge", 0.0))
            rec.update(_alignment_scores(frames, truth))
        elif method == "no alignment":
            q = flat_rotations(n, len(moving))
            rec.update(_no_alignment_scores())
        else:
            frames = {}
            for s in side_joints:
                t0 = time.perf_counter()
                if method == "oracle":
                    frames[s] = oracle_frames(truth)
                elif method == "uniform scaling":
                    frames[s] = uniform_frames(n, hands.n_frames)
                else:  # generic DTW
                    h = inputs.get("both", inputs.get(s))
                    h_arm = roles.sides[s] if "both" in inputs else find_roles(h.skeleton, source=h.source).sides[s]
                    frames[s] = generic_dtw_frames(body, h, roles.sides[s], h_arm, roles.up, window=generic_window)
                rec["t_align"] += time.perf_counter() - t0
            t0 = time.perf_counter()
            q = np.array(ref)
            for s, ks in side_joints.items():
                q[:, ks] = sample_rotations(hands.rotations[:, [moving[k] for k in ks]], frames[s])
            rec["t_merge"] = time.perf_counter() - t0
            rec.update(_alignment_scores(frames, truth))
        rec["t_total"] = time.perf_counter() - t_start
        rec["finger_deg"] = float(np.mean(quat_angle_deg(q, ref)))
        records.append(rec)
    return records


def evaluate(takes, *, seeds: int = 5, seed0: int = 0, params: SeparationParams | None = None,
             methods=METHODS, generic_window: int | None = None, splice_options: dict | None = None,
             progress=None, hands_form: str = "full", mirror: bool = False) -> pd.DataFrame:
    """Separate each take with ``seeds`` seeds, run every method, score it.

    Parameters
    ----------
    takes : sequence of Motion
        Full-body takes with moving fingers.
    seeds : int
        Number of seeds per take (seeds ``seed0 .. seed0 + seeds - 1``).
    params : SeparationParams, optional
        Separation options (ALGORITHM.md section 8 by default).
    progress : callable, optional
        ``progress(message: str)`` after each run.
    hands_form, mirror
        The form of the hands capture (see :func:`hands_inputs`).

    Returns
    -------
    pd.DataFrame
        One row per (take, seed, method): ``take``, ``seed``, ``method`` and the :data:`METRICS`.
        See :func:`summarize` for the table.
    """
    if seeds < 1:
        raise SplicerError(f"seeds must be >= 1, not {seeds}")
    p = params or SeparationParams()
    rows = []
    for take in takes:
        name = Path(take.source).name if take.source else "take"
        for seed in range(seed0, seed0 + seeds):
            t0 = time.perf_counter()
            sep = separate(take, rng=np.random.default_rng(seed), hands_fps=p.rate_ratio * take.fps,
                           warp_speed=p.warp_speed, amplitude=p.amplitude, yaw_deg=p.yaw_deg,
                           noise_deg=p.noise_deg, warp_sigma_s=p.warp_sigma_s)
            recs = evaluate_pair(take, sep, methods=methods, generic_window=generic_window,
                                 splice_options=splice_options, hands_form=hands_form, mirror=mirror)
            for r in recs:
                rows.append({"take": name, "seed": seed, **r})
            if progress is not None:
                full = {r["method"]: r for r in recs}.get("full, smooth time map")
                extra = f", full method {full['align_mean']:.2f} frames / {full['finger_deg']:.2f} deg" if full else ""
                progress(f"{name} seed {seed}: yaw {sep.params['yaw_deg']:+.1f} deg, {sep.hands.n_frames} hands "
                         f"frames{extra} ({time.perf_counter() - t0:.1f} s)")
    return pd.DataFrame(rows)


def default_takes(paths=(), *, synthetic_seconds: float = 60.0, note=print) -> list[Motion]:
    """Read the takes named by ``paths`` (files or folders of ``.bvh``), by default
    ``../shared/motions/zeggs``; without any, a synthetic take (and ``note`` says so)."""
    from ..io.bvh import read_bvh
    from .synth import make_gesture_take

    files = []
    where = [Path(p) for p in paths] or [SHARED_ZEGGS]
    for p in where:
        if p.is_dir():
            files.extend(sorted(p.glob("*.bvh")))
        elif p.is_file():
            files.append(p)
        elif paths:
            raise SplicerError(f"{p}: no such file or folder")
    if files:
        return [read_bvh(f) for f in files]
    note(f"no BVH found in {', '.join(str(p) for p in where)}: using a SYNTHETIC take instead "
         f"(make_gesture_take({synthetic_seconds:g} s, 30 fps, seed 0)) - not real capture data")
    return [make_gesture_take(synthetic_seconds, 30.0, np.random.default_rng(0))]


def _header(takes, runs, p: SeparationParams, generic_window) -> str:
    names = ", ".join(f"{Path(t.source).name if t.source else 'synthetic'} ({t.n_frames} frames @ {t.fps:g} fps)"
                      for t in takes)
    seeds = sorted(set(runs["seed"]))
    return (f"Takes: {names}. Seeds: {seeds[0]}..{seeds[-1]} ({len(seeds)} per take).\n"
            f"Separation (ALGORITHM.md 8): {asdict(p)}.\n"
            f"Generic DTW: dtaidistance, {'full' if generic_window is None else f'window {generic_window}'}; "
            "oracle, uniform and generic DTW sample the fingers by slerp at their frames (counted as merge; "
            "the generic DTW's marker extraction is counted in its alignment time).\n"
            "Each metric: mean over runs, worst run beside it. Alignment error in body frames (a body frame a "
            "method leaves uncovered is scored with its nearest covered hands frame; 'uncovered' is their share); "
            "finger error in degrees (geodesic) over moving finger joints; times in seconds for both sides.\n")


def build_parser() -> argparse.ArgumentParser:
    d = SeparationParams()
    p = argparse.ArgumentParser(prog="splicer-evaluate", description=(
        "Evaluation protocol of ALGORITHM.md section 8: separate full-body takes with moving fingers into "
        "body/hands/truth, run the splice and the baselines, print one table and write it as CSV and markdown."))
    p.add_argument("bvh", nargs="*", help=f"BVH files or folders (default: {SHARED_ZEGGS}; "
                   "a synthetic take when absent)")
    p.add_argument("--seeds", type=int, default=5, help="seeds per take (default 5)")
    p.add_argument("--seed0", type=int, default=0, help="first seed (default 0)")
    p.add_argument("--out", default=None, help="write OUT.csv and OUT.md (e.g. benchmarks/results_accuracy)")
    p.add_argument("--rate-ratio", type=float, default=d.rate_ratio, help="hands fps / body fps (default 2)")
    p.add_argument("--warp-speed", type=float, nargs=2, default=d.warp_speed, metavar=("LO", "HI"),
                   help="local speed range of the time warp (default 0.5 2)")
    p.add_argument("--amplitude", type=float, nargs=2, default=d.amplitude, metavar=("LO", "HI"),
                   help="arm/torso pull factor range (default 0.25 0.7)")
    p.add_argument("--yaw", type=float, nargs=2, default=d.yaw_deg, metavar=("LO", "HI"),
                   help="turn of the hands capture about the vertical, degrees (default 25 60)")
    p.add_argument("--noise-deg", type=float, default=d.noise_deg, help="finger/wrist noise, degrees (default 0.5)")
    p.add_argument("--warp-sigma-s", type=float, default=d.warp_sigma_s, help="warp smoothness, seconds (default 1.5)")
    p.add_argument("--generic-window", type=int, default=None, help="Sakoe-Chiba window of the generic DTW, frames "
                   "(default: full DTW)")
    p.add_argument("--hands-form", choices=HANDS_FORMS, default="full", help="hands capture as the full skeleton, "
                   "or per side as a forearm-rooted (Leap-like) or wrist-rooted (ManipNet-like) hand file")
    p.add_argument("--mirror", action="store_true", help="reflect the hands capture through X = 0, names kept "
                   "(as the ManipNet files are)")
    p.add_argument("--synthetic-seconds", type=float, default=60.0, help="length of the synthetic fallback take")
    # --- scenarios of real sessions (issue 8; splicer.scenarios, splicer.scenario_eval) ---
    p.add_argument("--scenario", action="append", default=None, metavar="NAME",
                   help="run a scenario instead of the plain protocol (repeatable): base, all, or components "
                        "joined by '+' from extra, extra-begin, extra-end, short, clip, pause-hands, pause-body, "
                        "speed, rate, imitation (e.g. extra+pause-hands); the scenario sets the rates and the "
                        "warp speed (--rate-ratio and --warp-speed apply to the plain protocol only)")
    p.add_argument("--scenarios", choices=["all"], default=None,
                   help="'all': every named scenario (base, extra, short, pause-hands, pause-body, speed, rate, "
                        "imitation, all)")
    p.add_argument("--synthetic", action="store_true",
                   help="scenarios: also run the synthetic take (make_gesture_take, --synthetic-seconds, seed 0)")
    p.add_argument("--splice-option", action="append", default=None, metavar="KEY=VALUE",
                   help="a SpliceOptions field for every splice method (repeatable; VALUE read as YAML); a method's "
                        "own setting wins (e.g. 'full, fixed ends' keeps ends=fixed)")
    p.add_argument("--runs-csv", action="append", default=None, metavar="CSV",
                   help="scenarios: tabulate earlier runs (OUT_runs.csv files, repeatable) instead of running")
    p.add_argument("--dump", default=None, metavar="DIR",
                   help="scenarios: also write DIR/<take>/<scenario>/seed<N>/{body.bvh,hands.bvh,truth.csv}")
    return p


def splice_option_args(items, err) -> dict | None:
    """``--splice-option KEY=VALUE`` items as a dict (VALUE read as YAML); None after reporting a malformed one."""
    import yaml

    opts = {}
    for kv in items or []:
        key, sep_, val = kv.partition("=")
        if not sep_ or not key.strip():
            err(f"splicer-evaluate: --splice-option needs KEY=VALUE, got {kv!r}")
            return None
        opts[key.strip()] = yaml.safe_load(val)
    return opts


def main(argv=None) -> int:
    args = build_parser().parse_args(argv)
    params = SeparationParams(args.rate_ratio, tuple(args.warp_speed), tuple(args.amplitude), tuple(args.yaw),
                              args.noise_deg, args.warp_sigma_s)

    def err(msg: str) -> None:
        print(msg, file=sys.stderr, flush=True)

    if args.scenario or args.scenarios or args.runs_csv:
        from .scenario_eval import scenario_cli
        return scenario_cli(args, params, err)
    opts = splice_option_args(args.splice_option, err)
    if opts is None:
        return 1
    try:
        takes = default_takes(args.bvh, synthetic_seconds=args.synthetic_seconds, note=lambda m: (print(m), err(m)))
        runs = evaluate(takes, seeds=args.seeds, seed0=args.seed0, params=params,
                        generic_window=args.generic_window, progress=err, hands_form=args.hands_form,
                        mirror=args.mirror, splice_options=opts or None)
    except SplicerError as e:
        err(f"splicer-evaluate: {e}")
        return 1
    except ValueError as e:  # bad separation parameters
        err(f"splicer-evaluate: {e}")
        return 1
    table = summarize(runs)
    header = _header(takes, runs, params, args.generic_window)
    if args.hands_form != "full" or args.mirror:  # issue 9 (c-handonly)
        header += (f"Hands capture: {args.hands_form}-rooted hand-only file per side" if args.hands_form != "full"
                   else "Hands capture: full skeleton") + (", mirrored through X = 0 (names kept)" if args.mirror
                                                           else "") + ".\n"
    if opts:
        header += f"Splice options for every splice method: {opts}.\n"
    verdict = checks(runs)
    print(header)
    print(compact_markdown(table))
    print("\n".join(verdict))
    if args.out:
        out = Path(args.out)
        out.parent.mkdir(parents=True, exist_ok=True)
        table.round(4).to_csv(out.with_suffix(".csv"))
        runs.round(4).to_csv(out.parent / (out.name + "_runs.csv"), index=False)
        out.with_suffix(".md").write_text(
            "# Accuracy (splicer-evaluate)\n\n" + header.replace("\n", "\n\n") + "\n" + compact_markdown(table)
            + "\n" + "\n".join(f"- {v}" for v in verdict) + "\n\n## All metrics\n\n" + to_markdown(table),
            encoding="utf-8")
        err(f"wrote {out.with_suffix('.csv')}, {out.name}_runs.csv and {out.with_suffix('.md')}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
