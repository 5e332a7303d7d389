"""Fit the risk model of splicer.align.risk on the ground-truth protocol's tuning seeds.

    python benchmarks/fit_risk.py [--seeds 4] [--seed0 0] [--jobs 2] [--out splicer/align/risk_model.py] [--data X.npz]

``--data``: the recorded frames are saved there (with each frame's take, scenario and seed, for
cross-validation by seed) or, when the file exists, read from it instead of splicing; a file
recorded over more seeds is cut to the ones asked for.

For each take (the shared zeggs take when ../shared/motions is present, and the synthetic
60-s speaker), every scenario of ``splicer-evaluate --scenarios`` and seeds ``seed0 ..
seed0+seeds-1`` (the tuning seeds 0-3; the README's figures use the held-out seeds 100-104):
make the scenario, splice it with the default options, and record, per side and covered body
frame, the signals the risk stage sees (:func:`splicer.stages.risk.side_risk_signals`, at the
point the pipeline calls it) and the frame's true alignment error.  Then fit the ordinal
logistic model of :mod:`splicer.align.risk` (one weight vector, one offset per rung of the
error ladder, a small ridge penalty; unweighted, so its probabilities are calibrated on the
protocol's mix of frames) and write the coefficients as a Python module.  Needs scipy.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

#: the error ladder t_k of the ordinal model, seconds
LADDER_S = (0.05, 0.1, 0.2, 0.4)
#: ridge penalty on the standardised weights
L2 = 1e-4


def _takes():
    from splicer.evaluation.evaluate import SHARED_ZEGGS
    from splicer.evaluation.synth import make_gesture_take
    from splicer.io.bvh import read_bvh

    out = []
    z = SHARED_ZEGGS / "067_Speech_2_x_1_0.bvh"
    if z.exists():
        out.append(("zeggs", lambda: read_bvh(z)))
    else:
        print(f"{z} absent: fitting on the synthetic take alone")
    out.append(("synthetic", lambda: make_gesture_take(60.0, 30.0, np.random.default_rng(0))))
    return out


def _one(job):
    """Splice one scenario; return (take, scenario, seed, features (k, d), errors (k,))."""
    import splicer.pipeline as P
    from splicer.align.risk import feature_names, risk_features
    from splicer.evaluation.scenario_scores import judged_error, report_flags
    from splicer.evaluation.scenarios import alignment_error_s, make_scenario, scenario
    from splicer.stages.risk import side_risk_signals

    take_name, sc, seed = job
    take = dict(_takes())[take_name]()
    seen = {}

    def record(sides, *a, **k):  # the risk stage's input, as the pipeline hands it over
        if len(sides) == 2:
            (sa, ra), (sb, rb) = sides.items()
            for s, r, o in ((sa, ra, rb), (sb, rb, ra)):
                sig = side_risk_signals(r, o)
                if sig is not None:
                    seen[s] = (sig, ~np.isfinite(np.asarray(r.hands_frame, float)), float(r.markers.spaces.body_fps))
        return dict(sides)

    P.estimate_risk = record
    sep = make_scenario(take, scenario(sc), rng=np.random.default_rng(seed))
    res = P.splice(sep.body, sep.hands)
    n = sep.body.n_frames
    X, E = [], []
    for s, sd in res.sides.items():
        if s not in seen:
            continue
        sig, unc_model, fps = seen[s]
        unc, _low = report_flags(res.report["sides"][s], n)
        e = judged_error(alignment_error_s(sep, np.asarray(sd.hands_frame, float)), sep.covered, unc)
        keep = np.isfinite(e) & ~unc
        F = dict(risk_features(sig, unc_model, fps))
        F = np.stack([F.get(k, np.full(n, np.nan)) for k in feature_names()], axis=1)  # NaN: the wrist's refinement did not run
        X.append(F[keep])
        E.append(e[keep])
    return take_name, sc, seed, np.concatenate(X), np.concatenate(E)


def fit(X: np.ndarray, err: np.ndarray, ladder=LADDER_S, l2: float = L2, families=(), nonneg=None):
    """Ordinal logistic fit: ``P(err > t_k) = sigmoid(z @ w - theta_k)``, z standardised.

    ``families``: lists of feature indices that move together when their signal rises by the
    same amount everywhere (a signal's value and its windows); for each, the score's change under
    such a rise, ``sum_j w_j / sd_j``, is held >= 0.  ``nonneg`` (boolean per feature): weights
    held >= 0."""
    from scipy.optimize import minimize

    mu, sd = X.mean(0), X.std(0)
    sd = np.where(sd > 0, sd, 1.0)
    Z = (X - mu) / sd
    t = np.asarray(ladder, float)
    Y = (err[:, None] > t[None, :]).astype(float)
    d = Z.shape[1]

    def f(p):
        w, th = p[:d], p[d:]
        s = (Z @ w)[:, None] - th[None, :]
        loss = (Y * np.logaddexp(0, -s) + (1 - Y) * np.logaddexp(0, s)).mean(0).sum() + l2 * (w ** 2).sum()
        r = (1 / (1 + np.exp(-s)) - Y) / len(err)
        return loss, np.r_[Z.T @ r.sum(1) + 2 * l2 * w, -r.sum(0)]

    rate = np.clip(Y.mean(0), 1e-4, 1 - 1e-4)
    p0 = np.r_[np.zeros(d), np.log((1 - rate) / rate)]
    nn = np.zeros(d, bool) if nonneg is None else np.asarray(nonneg, bool)
    bounds = [(0.0, None) if b else (None, None) for b in nn] + [(None, None)] * len(t)
    if families:
        from scipy.optimize import LinearConstraint
        A = np.zeros((len(families), d + len(t)))
        for i, fam in enumerate(families):
            A[i, list(fam)] = 1.0 / sd[list(fam)]
        r = minimize(f, p0, jac=True, method="SLSQP", constraints=[LinearConstraint(A, 0.0, np.inf)], bounds=bounds,
                     options=dict(maxiter=2000, ftol=1e-10))
    else:
        r = minimize(f, p0, jac=True, method="L-BFGS-B", bounds=bounds, options=dict(maxiter=5000))
    if not r.success:
        print("warning: the fit did not converge:", r.message)
    return mu, sd, r.x[:d], r.x[d:]


def write_models(path: Path, models: dict, doc: str) -> None:
    """``models``: variable name -> (names, mu, sd, w, th, fitted_on)."""
    def arr(a):
        return "(" + ", ".join(repr(float(x)) for x in a) + ",)"
    text = f'''"""The risk model's coefficients (:mod:`splicer.align.risk`), written by ``benchmarks/fit_risk.py``.

{doc}
"""
from .risk import RiskModel
'''
    for var, (names, mu, sd, w, th, fitted_on) in models.items():
        text += f'''
{var} = RiskModel(
    features={tuple(names)!r},
    mean={arr(mu)},
    scale={arr(sd)},
    weights={arr(w)},
    thresholds_s={arr(LADDER_S)},
    offsets={arr(th)},
    fitted_on={fitted_on!r},
)
'''
    path.write_text(text)


def fit_model(X: np.ndarray, E: np.ndarray, names) -> tuple:
    """Fit the ordinal model on features ``X`` (columns ``names``); print its summary."""
    # monotone in the evidence: more spread, disagreement or departure everywhere never lowers the estimate
    fams = [[j for j, n in enumerate(names) if n == base or n.startswith(base + "_")]
            for base in names if base.startswith("log_") and "_m" not in base.removeprefix("log_")]
    # and the levels in seconds, held >= 0: a signal far too large everywhere is risk, whatever the
    # logarithms' contrasts say
    mu, sd, w, th = fit(X, E, families=fams, nonneg=[n.endswith("_level") for n in names])
    order = np.argsort(-np.abs(w))
    print(f"{len(E)} frames, {100 * np.mean(E > 0.1):.1f} % more than 0.1 s off; offsets {np.round(th, 3).tolist()}")
    print("largest weights: " + ", ".join(f"{names[i]} {w[i]:+.2f}" for i in order[:8]))
    return mu, sd, w, th


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--seeds", type=int, default=4)
    p.add_argument("--seed0", type=int, default=0)
    p.add_argument("--jobs", type=int, default=2)
    p.add_argument("--out", type=Path, default=ROOT / "splicer" / "align" / "risk_model.py")
    p.add_argument("--data", type=Path, default=None, help="save/load the recorded frames here (.npz)")
    a = p.parse_args(argv)
    from splicer.align.risk import feature_names
    from splicer.evaluation.scenario_types import SCENARIOS

    names = feature_names()  # the wrist's signals included; NaN where its refinement did not run
    if a.data is not None and a.data.exists():
        z = np.load(a.data)
        X, E, takes = z["X"], z["E"], [str(x) for x in z["takes"]]
        if X.shape[1] != len(names):
            raise SystemExit(f"{a.data} was recorded with {X.shape[1]} features, the code has {len(names)}: record it again")
        if "seed" in z.files:  # recorded over more seeds than asked for: keep the asked ones
            keep = (z["seed"] >= a.seed0) & (z["seed"] < a.seed0 + a.seeds)
            X, E = X[keep], E[keep]
    else:
        jobs = [(t, sc, s) for t, _ in _takes() for sc in SCENARIOS for s in range(a.seed0, a.seed0 + a.seeds)]
        t0 = time.time()
        os.environ.setdefault("NUMBA_NUM_THREADS", "1")
        if a.jobs > 1:
            import multiprocessing as mp
            with mp.get_context("spawn").Pool(a.jobs) as pool:
                rows = pool.map(_one, jobs, chunksize=1)
        else:
            rows = [_one(j) for j in jobs]
        print(f"{len(jobs)} splices in {time.time() - t0:.0f} s")
        X = np.concatenate([r[3] for r in rows])
        E = np.concatenate([r[4] for r in rows])
        takes = sorted({r[0] for r in rows})
        if a.data is not None:  # with each frame's take, scenario and seed, for cross-validation
            lab = [np.full(len(r[4]), i) for i, r in enumerate(rows)]
            lab = np.concatenate(lab)
            np.savez_compressed(a.data, X=X, E=E, takes=np.array(takes),
                                take=np.array([r[0] for r in rows])[lab], scenario=np.array([r[1] for r in rows])[lab],
                                seed=np.array([r[2] for r in rows])[lab])
    wrist = np.isfinite(X).all(axis=1)  # frames of sides the wrist's refinement ran on
    cols = [j for j, nm in enumerate(names) if nm in set(feature_names(wrist=False))]
    what = (f"takes {', '.join(takes)}, every scenario, seeds {a.seed0}-{a.seed0 + a.seeds - 1}, both sides, "
            "default options")
    models = {}
    for var, rows, use in (("MODEL", wrist, list(range(len(names)))), ("MODEL_NO_WRIST", np.ones(len(E), bool), cols)):
        print(var)
        fitted = fit_model(X[rows][:, use], E[rows], [names[j] for j in use])
        models[var] = ([names[j] for j in use], *fitted,
                       f"Fitted on {int(rows.sum())} covered body frames of the ground-truth protocol: {what}; "
                       f"{100 * np.mean(E[rows] > 0.1):.1f} % of them more than 0.1 s off.")
    write_models(a.out, models, "MODEL: a side the wrist's refinement ran on (its signals included); MODEL_NO_WRIST: "
                 "any other side (the same fit without them).\n\n" + models["MODEL"][-1])
    print("wrote", a.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
