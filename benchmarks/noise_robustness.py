"""How far tiny input noise moves the splice of the bundled sample (issue 13).

Gaussian noise of ``sigma`` degrees on every rotation channel of both takes (seeded), then
the splice again: the largest change of each side's time map (hands frames), of pass 1's
path, and of the output's finger rotations (degrees).  ``python benchmarks/noise_robustness.py``.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # run from a checkout without installing

from splicer.io.bvh import read_bvh  # noqa: E402
from splicer.model.rotations import quat_angle_deg  # noqa: E402
from splicer.options import SpliceOptions  # noqa: E402
from splicer.pipeline import splice  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
BODY, HANDS, SYNC = (ROOT / "motions" / n for n in ("sample_body.bvh", "sample_hands.bvh", "sample_sync.yaml"))


def noisy(m, sigma, rng):
    sk = m.skeleton
    cols = [c for j in range(sk.n_joints) for c in sk.rotation_columns(j)]
    ch = np.array(m.channels)
    ch[:, cols] += rng.normal(0.0, sigma, size=(m.n_frames, len(cols)))
    return m.with_channels(ch)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sigmas", type=float, nargs="+", default=[1e-6, 1e-5, 1e-4, 1e-3, 1e-2])
    ap.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2])
    ap.add_argument("--option", action="append", default=[], metavar="KEY=VALUE",
                    help="a SpliceOptions field (number), e.g. dead_zone=0.1")
    a = ap.parse_args(argv)
    opts = SpliceOptions(**{k: float(v) for k, v in (o.split("=", 1) for o in a.option)})
    body, hands = read_bvh(BODY), read_bvh(HANDS)
    ref = splice(body, hands, config=SYNC, options=opts)
    print("sigma_deg  seed  max|dtm| L  max|dtm| R  max|dpath1|  max dangle_deg")
    for s in a.sigmas:
        for seed in a.seeds:
            rng = np.random.default_rng(seed)
            r = splice(noisy(body, s, rng), noisy(hands, s, rng), config=SYNC, options=opts)
            dtm = {k: float(np.nanmax(np.abs(r.sides[k].hands_frame - ref.sides[k].hands_frame))) for k in r.sides}
            dp = 0.0
            for k in r.sides:
                p, q = r.sides[k].pass1.path, ref.sides[k].pass1.path
                dp = max(dp, np.inf if p.shape != q.shape else float(np.abs(p - q).max()))
            ang = float(quat_angle_deg(r.motion.rotations, ref.motion.rotations).max())
            print(f"{s:9.0e}  {seed:4d}  {dtm.get('left', 0):10.4f}  {dtm.get('right', 0):10.4f}  {dp:11.1f}  {ang:14.5f}")


if __name__ == "__main__":
    main()
