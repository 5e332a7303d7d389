"""Marker-based alignment beside the virtual-marker one, on the ground-truth protocol (issue 14).

For each seed, :func:`splicer.evaluation.separate.separate` splits the take into body, hands and truth;
:func:`splicer.evaluation.marker_synth.skin_markers` makes each session's optical markers (styloids,
forearm cluster, hand and shoulder-girdle markers at fixed skin offsets, 1-2 mm noise,
occlusion gaps of 0.05-1 s, six per marker and minute, at 100 Hz for the hands and 120 Hz for
the body); they are written as C3D and read back, then the splice aligns on

* virtual markers of both BVHs (today's method),
* the hands C3D (``--hands-markers``) and the body's virtual markers,
* both C3Ds (``--hands-markers --body-markers``),
* the same two with the markers derived from rigid segment fits (``markers: derive: rigid``,
  :mod:`splicer.rig.segment_fit`) instead of role averages,

all with the default options (full method, smooth time map, open ends); and, to show where the
difference comes from, both C3D without noise and gaps, with noise only, with gaps only (and rigid
segments without noise and gaps).  Alignment error: body frames,
as in :mod:`splicer.evaluation.evaluate` (a body frame left uncovered is scored with the nearest covered hands frame;
"uncovered" is their share).

    python benchmarks/eval_markers.py [--seeds 100 101 102 103 104] [--out benchmarks/results_markers.md]

Two takes, as the scenario protocol: the shared ZEGGS take (skipped with a note when absent) and
the synthetic speaker the project makes (:func:`splicer.evaluation.evaluate.default_takes`).
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

import numpy as np
import pandas as pd

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from splicer.io.bvh import read_bvh  # noqa: E402
from splicer.io.config import SpliceConfig  # noqa: E402
from splicer.evaluation.evaluate import _alignment_scores  # noqa: E402
from splicer.evaluation.marker_synth import skin_markers  # noqa: E402
from splicer.pipeline import splice  # noqa: E402
from splicer.evaluation.separate import separate  # noqa: E402
from splicer.io.trajectories import read_c3d  # noqa: E402
from splicer.io.trajectory_writers import write_c3d  # noqa: E402

TAKE = ROOT.parent / "shared" / "motions" / "zeggs" / "067_Speech_2_x_1_0.bvh"
METHODS = ("virtual markers (both BVHs)", "hands C3D + body virtual", "both C3D", "hands C3D, rigid segments",
           "both C3D, rigid segments")
#: Where the loss comes from: both C3D with parts of the degradation switched off.
ABLATIONS = {"both C3D, no noise, no gaps": dict(noise_mm=(0.0, 0.0), gaps_per_minute=0.0),
             "both C3D, noise only": dict(gaps_per_minute=0.0),
             "both C3D, gaps only": dict(noise_mm=(0.0, 0.0))}
#: The markers derived from rigid segment fits (``markers: derive: rigid``) instead of role averages.
RIGID = SpliceConfig(markers={"body": {"derive": "rigid"}, "hands": {"derive": "rigid"}})
VARIANTS = {"both C3D, rigid segments, no noise, no gaps": dict(config=RIGID, noise_mm=(0.0, 0.0), gaps_per_minute=0.0)}


def run(take, seeds, *, hands_fps=100.0, body_fps=120.0) -> pd.DataFrame:
    take = take if not isinstance(take, (str, Path)) else read_bvh(take)
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for seed in seeds:
            sep = separate(take, rng=np.random.default_rng(seed))
            rng = np.random.default_rng(seed + 1000)
            write_c3d(skin_markers(sep.hands, rng=rng, fps=hands_fps), Path(tmp) / "hands.c3d")
            write_c3d(skin_markers(sep.body, rng=rng, fps=body_fps), Path(tmp) / "body.c3d")
            th, tb = read_c3d(Path(tmp) / "hands.c3d"), read_c3d(Path(tmp) / "body.c3d")
            missing = 100.0 * float(np.mean(np.concatenate([th.missing.ravel(), tb.missing.ravel()])))
            for method, kw in zip(METHODS, ({}, {"hands_markers": th}, {"hands_markers": th, "body_markers": tb},
                                            {"hands_markers": th, "config": RIGID},
                                            {"hands_markers": th, "body_markers": tb, "config": RIGID})):
                r = splice(sep.body, sep.hands, **kw)
                sc = _alignment_scores({s: v.hands_frame for s, v in r.sides.items()}, sep.truth)
                fills = sum(len(v.markers.real.get(k, {}).get("gaps_filled", [])) for v in r.sides.values()
                            for k in ("body", "hands"))
                rows.append({"seed": seed, "method": method, **sc, "missing_pct": missing, "gaps_filled": fills})
                print(seed, method, {k: round(v, 3) for k, v in sc.items()}, flush=True)
            for method, kw in (ABLATIONS | VARIANTS).items():
                kw = dict(kw)
                cfg = kw.pop("config", None)
                rng = np.random.default_rng(seed + 1000)
                th = skin_markers(sep.hands, rng=rng, fps=hands_fps, **kw)
                tb = skin_markers(sep.body, rng=rng, fps=body_fps, **kw)
                r = splice(sep.body, sep.hands, hands_markers=th, body_markers=tb, config=cfg)
                sc = _alignment_scores({s: v.hands_frame for s, v in r.sides.items()}, sep.truth)
                rows.append({"seed": seed, "method": method, **sc, "missing_pct": np.nan, "gaps_filled": np.nan})
                print(seed, method, {k: round(v, 3) for k, v in sc.items()}, flush=True)
    return pd.DataFrame(rows)


def to_markdown(df: pd.DataFrame, take_name: str) -> str:
    g = df.groupby("method", sort=False)
    lines = [f"Take: {take_name}; seeds {', '.join(str(s) for s in sorted(df.seed.unique()))}; "
             f"markers missing: {df.missing_pct.mean():.1f}% of samples (gaps 0.05-1 s).", "",
             "| alignment on | mean error, frames (worst seed) | max error, frames | within 1 frame, % | "
             "within 3 frames, % | uncovered, % |", "|---|---:|---:|---:|---:|---:|"]
    for m, d in g:
        lines.append(f"| {m} | {d.align_mean.mean():.2f} ({d.align_mean.max():.2f}) | {d.align_max.mean():.1f} | "
                     f"{d.within_1.mean():.1f} | {d.within_3.mean():.1f} | {d.uncovered.mean():.1f} |")
    base = df[df.method == METHODS[0]].set_index("seed").align_mean
    for m in METHODS[1:] + tuple(ABLATIONS) + tuple(VARIANTS):
        d = df[df.method == m].set_index("seed").align_mean
        lines.append("")
        lines.append(f"- {m}: at least as accurate as virtual markers in {(d <= base).sum()}/{len(d)} seeds; "
                     f"mean difference {float((d - base).mean()):+.2f} frames.")
    return "\n".join(lines) + "\n"


SHARED_C3D = ROOT.parent / "shared" / "motions" / "c3d" / "markers_analogs.c3d"


def gapfill_validation(path: Path = SHARED_C3D, lengths_s=(0.1, 0.3, 0.6), trials: int = 40, seed: int = 0) -> str:
    """Leave-out check of gap filling on the real capture: hide a seen stretch of a role marker, fill it
    (rigid from its segment; following the pattern of its two nearest segment mates, as when too few
    are seen for a rigid fit; cubic alone), RMS distance to the hidden samples, median over trials."""
    import dataclasses

    from splicer.rig.gapfill import fill_gaps
    from splicer.rig.marker_roles import find_marker_roles
    from splicer.io.trajectories import read_trajectories

    t = read_trajectories(path)
    roles = find_marker_roles(t, "right")
    cols = sorted({c for v in roles.roles.values() for c in v})
    rng = np.random.default_rng(seed)
    lines = [f"Gap filling, leave-out on {path.name} (role markers; RMS error of the filled samples, mm, median of "
             f"{trials} trials):", "", "| gap, s | rigid from the segment | pattern of two segment mates | cubic alone |",
             "|---:|---:|---:|---:|"]
    for length in lengths_s:
        n = int(round(length * t.fps))
        err = {"segment": [], "pattern": [], "alone": []}
        for _ in range(trials):
            c = int(rng.choice(cols))
            a = int(rng.integers(5, t.n_frames - n - 5))
            if t.missing[a - 1:a + n + 1, c].any():
                continue
            p = np.array(t.points)
            p[a:a + n, c] = np.nan
            for key, segs, need in (("segment", roles.segments, 3), ("pattern", roles.segments, 99), ("alone", None, 3)):
                g = fill_gaps(dataclasses.replace(t, points=p), segs, columns=[c], min_donors=need)
                e = np.linalg.norm(g.trajectories.points[a:a + n, c] - t.points[a:a + n, c], axis=1)
                err[key].append(float(np.sqrt(np.mean(e ** 2))))
        lines.append(f"| {length:g} | {np.median(err['segment']):.1f} | {np.median(err['pattern']):.1f} | "
                     f"{np.median(err['alone']):.1f} |")
    return "\n".join(lines) + "\n"


def real_warp_check(path: Path = SHARED_C3D) -> str:
    """The real capture against itself re-timed by a known smooth warp, sampled at 120 Hz:
    ``splice-markers``' time map against the known one, in frames of the body file (100 Hz)."""
    import dataclasses

    from splicer.markers_cli import align_marker_files, retime
    from splicer.io.trajectories import read_c3d

    t = read_c3d(path)
    m = int((t.n_frames - 1) / t.fps * 120.0) + 1
    u = np.linspace(0.0, 1.0, m)
    src = (u + 0.06 * np.sin(2 * np.pi * u) + 0.03 * np.sin(4 * np.pi * u)) * (t.n_frames - 1)
    speed = np.gradient(src) / (t.fps / 120.0)
    h = dataclasses.replace(t, points=retime(t, src, fps=120.0, first_frame=1), fps=120.0, source="warped.c3d")
    from splicer.align.passes import hold_ends

    tm = align_marker_files(t, h).time_maps["right"]
    truth = np.interp(np.arange(t.n_frames), src, np.arange(m))
    uncovered = 100.0 * float(np.mean(~np.isfinite(tm)))
    err = np.abs(hold_ends(tm) - truth) * t.fps / 120.0  # uncovered frames: the nearest covered hands frame
    return (f"Real capture: {path.name} aligned by `splice-markers` to itself re-timed by a known smooth warp "
            f"(speed {speed.min():.2f}-{speed.max():.2f}x) at 120 Hz, gaps included: mean error {err.mean():.2f} "
            f"body frames (100 Hz), worst {err.max():.2f}, {100 * np.mean(err <= 1):.0f}% within 1 frame, "
            f"{uncovered:.1f}% of body frames left uncovered.\n")


def main(argv=None) -> int:
    from splicer.evaluation.synth import make_gesture_take

    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--take", type=Path, nargs="*", default=None,
                   help="BVH takes (default: the ZEGGS take when present, and the synthetic speaker)")
    p.add_argument("--seeds", type=int, nargs="+", default=[100, 101, 102, 103, 104])
    p.add_argument("--out", type=Path, default=ROOT / "benchmarks" / "results_markers.md")
    args = p.parse_args(argv)
    if args.take:
        takes = [(t.name, t) for t in args.take]
    else:
        takes = [(TAKE.name, TAKE)] if TAKE.exists() else []
        if not takes:
            print(f"{TAKE} is absent: the synthetic speaker alone")
        takes.append(("synthetic speaker (make_gesture_take(60 s, 30 fps, seed 0))",
                      make_gesture_take(60.0, 30.0, np.random.default_rng(0))))
    frames, text = [], ""
    for name, take in takes:
        df = run(take, args.seeds)
        df.insert(0, "take", name)
        frames.append(df)
        text += ("\n" if text else "") + to_markdown(df.drop(columns="take"), name)
    pd.concat(frames).to_csv(args.out.with_suffix(".csv"), index=False)
    if SHARED_C3D.exists():
        text += "\n" + gapfill_validation() + "\n" + real_warp_check()
    args.out.write_text("# Marker-based alignment (benchmarks/eval_markers.py)\n\n" + text)
    print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
