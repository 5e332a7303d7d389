"""Marker-based alignment beside the virtual-marker one, on the ground-truth protocol (issue 14).

For each seed, :func:`splicer.separate.separate` splits the take into body, hands and truth;
:func:`splicer.marker_synth.skin_markers` makes each session's optical markers (styloids,
forearm cluster, hand and shoulder-girdle markers at fixed skin offsets, 1-2 mm noise,
occlusion gaps of 0.05-1 s, six per marker and minute, at 100 Hz for the hands and 120 Hz for
the body); they are written as C3D and read back, then the splice aligns on

* virtual markers of both BVHs (today's method),
* the hands C3D (``--hands-markers``) and the body's virtual markers,
* both C3Ds (``--hands-markers --body-markers``),

all with the default options (full method, smooth time map).  Alignment error: body frames,
as in :mod:`splicer.evaluate`.

    python benchmarks/eval_markers.py [--seeds 100 101 102 103 104] [--out notes/eval_markers.md]
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

from splicer.bvh import read_bvh  # noqa: E402
from splicer.evaluate import _alignment_scores  # noqa: E402
from splicer.marker_synth import skin_markers  # noqa: E402
from splicer.pipeline import splice  # noqa: E402
from splicer.separate import separate  # noqa: E402
from splicer.trajectories import read_c3d, write_c3d  # noqa: E402

TAKE = ROOT.parent / "shared" / "motions" / "zeggs" / "067_Speech_2_x_1_0.bvh"
METHODS = ("virtual markers (both BVHs)", "hands C3D + body virtual", "both C3D")


def run(take_path: Path, seeds, *, hands_fps=100.0, body_fps=120.0) -> pd.DataFrame:
    take = read_bvh(take_path)
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for seed in seeds:
            sep = separate(take, rng=np.random.default_rng(seed))
            rng = np.random.default_rng(seed + 1000)
            write_c3d(skin_markers(sep.hands, rng=rng, fps=hands_fps), Path(tmp) / "hands.c3d")
            write_c3d(skin_markers(sep.body, rng=rng, fps=body_fps), Path(tmp) / "body.c3d")
            th, tb = read_c3d(Path(tmp) / "hands.c3d"), read_c3d(Path(tmp) / "body.c3d")
            missing = 100.0 * float(np.mean(np.concatenate([th.missing.ravel(), tb.missing.ravel()])))
            for method, kw in zip(METHODS, ({}, {"hands_markers": th}, {"hands_markers": th, "body_markers": tb})):
                r = splice(sep.body, sep.hands, **kw)
                sc = _alignment_scores({s: v.hands_frame for s, v in r.sides.items()}, sep.truth)
                fills = sum(len(v.markers.real.get(k, {}).get("gaps_filled", [])) for v in r.sides.values()
                            for k in ("body", "hands"))
                rows.append({"seed": seed, "method": method, **sc, "missing_pct": missing, "gaps_filled": fills})
                print(seed, method, {k: round(v, 3) for k, v in sc.items()}, flush=True)
    return pd.DataFrame(rows)


def to_markdown(df: pd.DataFrame, take_path: Path) -> str:
    g = df.groupby("method", sort=False)
    lines = [f"Take: {take_path.name}; seeds {', '.join(str(s) for s in sorted(df.seed.unique()))}; "
             f"markers missing: {df.missing_pct.mean():.1f}% of samples (gaps 0.05-1 s).", "",
             "| alignment on | mean error, frames (worst seed) | max error, frames | within 1 frame, % | "
             "within 3 frames, % |", "|---|---:|---:|---:|---:|"]
    for m, d in g:
        lines.append(f"| {m} | {d.align_mean.mean():.2f} ({d.align_mean.max():.2f}) | {d.align_max.mean():.1f} | "
                     f"{d.within_1.mean():.1f} | {d.within_3.mean():.1f} |")
    base = df[df.method == METHODS[0]].set_index("seed").align_mean
    for m in METHODS[1:]:
        d = df[df.method == m].set_index("seed").align_mean
        lines.append("")
        lines.append(f"- {m}: at least as accurate as virtual markers in {(d <= base).sum()}/{len(d)} seeds; "
                     f"mean difference {float((d - base).mean()):+.2f} frames.")
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--take", type=Path, default=TAKE)
    p.add_argument("--seeds", type=int, nargs="+", default=[100, 101, 102, 103, 104])
    p.add_argument("--out", type=Path, default=ROOT / "benchmarks" / "results_markers.md")
    args = p.parse_args(argv)
    df = run(args.take, args.seeds)
    df.to_csv(args.out.with_suffix(".csv"), index=False)
    text = to_markdown(df, args.take)
    args.out.write_text("# Marker-based alignment (benchmarks/eval_markers.py)\n\n" + text)
    print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
