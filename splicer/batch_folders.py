"""The folders mode of ``splice-batch``: pair every hands take with a body take (:mod:`splicer.batch`).

The take signatures and the candidate costs (:mod:`splicer.pairing`) are computed as Dask
tasks; the cost table and the decisions are written as ``pairing.md`` and ``pairing.csv``;
each accepted pair becomes a :class:`~splicer.manifest.PairJob`.
"""

from __future__ import annotations

import csv
import io
import math
from pathlib import Path

from .batch_summary import _write_atomic
from .errors import SplicerError
from .manifest import PairJob

__all__ = ["pair_folders"]


def _cost_row(hands_sig, body_sigs, band):
    from .pairing import pair_cost

    if hands_sig.error:
        return [math.nan] * len(body_sigs)
    return [math.nan if b.error else pair_cost(b, hands_sig, band=band) for b in body_sigs]


def pair_folders(body_dir, hands_dir, out_dir, client, *, fps: float = 5.0, margin: float | None = None,
                 max_cost: float | None = None, band: str = "60%", options: dict | None = None, note=None):
    """Pair each hands take of ``hands_dir`` with a body take of ``body_dir`` by coarse alignment cost.

    Writes ``pairing.md`` and ``pairing.csv`` (the cost table and the decisions) to ``out_dir``.

    Returns
    -------
    jobs : list of PairJob
        One per accepted pair: output ``<out_dir>/<body stem>.bvh``, name the body stem.
    decisions : list of PairDecision
    costs : np.ndarray [shape=(n_hands, n_body)]
        Pass-1 D1 cost per path step at ``fps``.
    """
    import numpy as np

    from .pairing import DEFAULT_MARGIN, cost_table_markdown, decide_pairs, take_signature

    margin = DEFAULT_MARGIN if margin is None else margin
    note = note or (lambda msg: None)
    bodies = sorted(str(p.resolve()) for p in Path(body_dir).glob("*.bvh"))
    hands = sorted(str(p.resolve()) for p in Path(hands_dir).glob("*.bvh"))
    for d, files, what in ((body_dir, bodies, "body"), (hands_dir, hands, "hands")):
        if not Path(d).is_dir():
            raise SplicerError(f"{d}: {what} folder not found")
        if not files:
            raise SplicerError(f"{d}: no .bvh files in the {what} folder")
    hands_side = (options or {}).get("hands_side")
    bsig = [client.submit(take_signature, b, fps=fps, pure=False) for b in bodies]
    hsig = [client.submit(take_signature, h, fps=fps, hands_side=hands_side, pure=False) for h in hands]
    rows = client.gather([client.submit(_cost_row, h, bsig, band, pure=False) for h in hsig])
    costs = np.array(rows, dtype=np.float64).reshape(len(hands), len(bodies))
    decisions = decide_pairs(costs, bodies, hands, margin=margin, max_cost=max_cost)
    sig_errors = {s.path: s.error for s in client.gather(bsig + hsig) if s.error}
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    md = [f"# Pairing: {len(hands)} hands takes x {len(bodies)} body takes", "",
          f"Cost: pass-1 phase metric D1 per path step (0..96) at {fps:g} fps, band {band}; "
          f"a pair needs the best cost at least {100 * margin:.0f}% below the runner-up (both ways).", "",
          cost_table_markdown(costs, bodies, hands), "", "| hands | body | cost | runner-up | margin | decision |",
          "|---|---|---:|---:|---:|---|"]
    for dcs in decisions:
        mg = f"{100 * dcs.margin:.0f}%" if math.isfinite(dcs.margin) else "-"
        md.append(f"| {Path(dcs.hands).name} | {Path(dcs.body).name if dcs.body else '-'} | {dcs.cost:.3g} | "
                  f"{dcs.second:.3g} | {mg} | {dcs.reason} |")
    for path, err in sig_errors.items():
        md.append(f"\n- {Path(path).name}: {err}")
    _write_atomic(out / "pairing.md", "\n".join(md) + "\n")
    buf = io.StringIO()
    w = csv.writer(buf)
    w.writerow(["hands"] + [Path(b).name for b in bodies] + ["paired_body", "margin", "decision"])
    for i, dcs in enumerate(decisions):
        w.writerow([Path(hands[i]).name] + [f"{v:.4f}" for v in costs[i]]
                   + [Path(dcs.body).name if dcs.body else "", f"{dcs.margin:.4f}", dcs.reason])
    _write_atomic(out / "pairing.csv", buf.getvalue())
    jobs = [PairJob(Path(d.body).stem, d.body, d.hands, str((out / f"{Path(d.body).stem}.bvh").resolve()),
                    None, dict(options or {})) for d in decisions if d.body]
    for d in decisions:
        note(f"{Path(d.hands).name}: " + (f"-> {Path(d.body).name} (cost {d.cost:.3g}, margin {100 * d.margin:.0f}%)"
                                          if d.body else f"refused: {d.reason}"))
    return jobs, decisions, costs
