"""The error's 95th percentile from the alignment's signals (align.risk, stages.risk): the
window helpers against slow references, the quantile's worked answers, the stage on the sample,
and the fit recovering a known model."""

from __future__ import annotations

import importlib.util
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from splicer import splice
from splicer.align.risk import (LOG_FLOOR_S, RiskModel, distance_to_uncovered, error_quantile, feature_names,
                                risk_features, risk_score, risk_signals, running_max, running_mean,
                                running_sum)
from splicer.align.risk_model import MODEL, MODEL_NO_WRIST
from splicer.defaults import RISK_QUANTILE
from splicer.stages.risk import estimate_risk, side_risk_signals

ROOT = Path(__file__).resolve().parents[1]
MOTIONS = ROOT / "motions"


def _slow_window(x, half, f):
    n = len(x)
    return np.array([f(x[max(0, i - half):min(n, i + half + 1)]) for i in range(n)])


@pytest.mark.parametrize("half", [0, 1, 2, 7, 40])
def test_running_windows_match_slow_reference(half):
    rng = np.random.default_rng(half)
    for n in (1, 2, 5, 33, 200):
        x = rng.normal(size=n)
        np.testing.assert_array_equal(running_max(x, half), _slow_window(x, half, np.max))
        np.testing.assert_allclose(running_mean(x, half), _slow_window(x, half, np.mean), rtol=1e-12, atol=1e-12)
        m = rng.normal(size=(n, 3, 3))  # any trailing shape, along the first axis
        np.testing.assert_allclose(running_sum(m, half), _slow_window(m, half, lambda w: w.sum(axis=0)), rtol=1e-12,
                                   atol=1e-12)


def test_distance_to_uncovered_matches_slow_reference():
    rng = np.random.default_rng(3)
    for n in (1, 4, 50):
        for p in (0.0, 0.05, 0.5, 1.0):
            u = rng.random(n) < p
            idx = np.flatnonzero(u)
            slow = np.array([np.min(np.abs(idx - i)) if len(idx) else np.inf for i in range(n)], float)
            np.testing.assert_array_equal(distance_to_uncovered(u), slow)


def _one_feature_model(weight=1.0, mean=0.0, scale=1.0):
    """A model that reads log_spread alone (every other weight 0)."""
    names = feature_names()
    d = len(names)
    w = np.zeros(d)
    w[names.index("log_spread")] = weight
    mu, sd = np.zeros(d), np.ones(d)
    mu[names.index("log_spread")], sd[names.index("log_spread")] = mean, scale
    return RiskModel(names, mu, sd, w, [0.05, 0.1, 0.2], [1.0, 2.0, 3.0])


def test_error_quantile_worked():
    m = _one_feature_model()
    logit = np.log(0.05 / 0.95)
    # P(error > t_k) = 0.05 exactly at score = theta_k + logit(0.05): the 95th percentile is t_k
    s = np.array([1.0, 2.0, 3.0]) + logit
    np.testing.assert_allclose(error_quantile(m, s, 0.95), [0.05, 0.1, 0.2])
    # halfway between two rungs: log-linear, the geometric mean
    np.testing.assert_allclose(error_quantile(m, np.array([1.5 + logit]), 0.95), [np.sqrt(0.05 * 0.1)])
    # beyond the ladder, the end rungs' slopes (a factor 2 per unit of score), clipped at max_s
    np.testing.assert_allclose(error_quantile(m, np.array([5.0 + logit, 0.0 + logit]), 0.95), [0.8, 0.025])
    assert error_quantile(m, np.array([1e3]), 0.95, max_s=60.0)[0] == 60.0
    # a higher quantile is a larger error; a higher score too
    s = np.linspace(-5, 10, 50)
    hi, lo = error_quantile(m, s, 0.99), error_quantile(m, s, 0.9)
    assert np.all(hi >= lo) and np.all((hi > lo) | (hi == 60.0))
    e = error_quantile(m, s, 0.95)
    assert np.all((np.diff(e) > 0) | (e[1:] == 60.0))
    for q in (0.0, 1.0, 1.5):
        with pytest.raises(ValueError, match="q must"):
            error_quantile(m, s, q)


def test_risk_model_checks_itself():
    names = feature_names()
    d = len(names)
    ok = dict(features=names, mean=np.zeros(d), scale=np.ones(d), weights=np.zeros(d),
              thresholds_s=[0.05, 0.1], offsets=[1.0, 2.0])
    RiskModel(**ok)
    for bad, match in (({"scale": np.zeros(d)}, "scale"), ({"weights": np.zeros(d - 1)}, "weights"),
                       ({"offsets": [2.0, 1.0]}, "offsets"), ({"thresholds_s": [0.1, 0.05]}, "thresholds_s"),
                       ({"mean": np.full(d, np.nan)}, "mean")):
        with pytest.raises(ValueError, match=match):
            RiskModel(**{**ok, **bad})
    m = RiskModel(**ok)
    np.testing.assert_allclose(m.probability_above(np.array([2.0, 1.0]), 0.1), [0.5, 1 / (1 + np.e)])
    with pytest.raises(ValueError, match="thresholds"):
        m.probability_above(np.zeros(1), 0.3)


def _signals(n=40, spread=0.02, wrist=True):
    z = np.zeros(n)
    rel = np.zeros((n, 4, 3))
    rel[:, :, 0] = np.sin(np.linspace(0, 6, n))[:, None]
    w = dict(wrist_sd_s=np.full(n, spread / 4), wrist_shift_s=np.full(n, np.nan)) if wrist else {}
    return risk_signals(spread_s=np.full(n, spread), disagreement_s=z, evidence_s=np.full(n, spread), own_s=z,
                        other_own_s=z, trend_sd_s=np.full(n, spread / 2), trend_shift_s=z, body_relative=rel,
                        other_body_relative=rel * 2, **w)


def test_risk_signals_and_features():
    sig = _signals()
    # speeds relative to their own root-mean-square: the other arm's doubled motion reads the same
    np.testing.assert_allclose(sig["speed"], sig["other_speed"])
    assert np.sqrt(np.mean(sig["speed"] ** 2)) == pytest.approx(1.0)
    np.testing.assert_allclose(sig["min_speed"], sig["speed"])
    unc = np.zeros(40, bool)
    unc[:3] = True
    feats = dict(risk_features(sig, unc, 30.0))
    assert tuple(feats) == feature_names()
    np.testing.assert_allclose(feats["log_spread"], np.log(0.02 + LOG_FLOOR_S))
    np.testing.assert_allclose(feats["log_trend_sd"], np.log(0.01 + LOG_FLOOR_S))
    np.testing.assert_allclose(feats["trend_shift_level"], 0.0)
    np.testing.assert_allclose(feats["edge"][:6], [0, 0, 0, 1 / 30, 2 / 30, 3 / 30])
    assert feats["edge"].max() == pytest.approx(37 / 30)
    np.testing.assert_array_equal(feats["edge_in"][:14], [1] * 13 + [0])  # within 1/3 s: 10 frames past the edge
    np.testing.assert_allclose(feats["log_wrist_sd"], np.log(0.005 + LOG_FLOOR_S))
    np.testing.assert_allclose(feats["wrist_shift_level"], 0.0)  # NaN (not measured) reads 0
    # a side the wrist's refinement did not run on: the same features less the wrist's
    plain = dict(risk_features(_signals(wrist=False), unc, 30.0))
    assert tuple(plain) == feature_names(wrist=False) and len(plain) < len(feats)
    assert not any("wrist" in k for k in plain)
    for k, v in plain.items():
        np.testing.assert_array_equal(v, feats[k])
    with pytest.raises(ValueError, match="both wrist signals"):
        risk_signals(spread_s=np.zeros(3), disagreement_s=np.zeros(3), evidence_s=np.zeros(3), own_s=np.zeros(3),
                     other_own_s=np.zeros(3), trend_sd_s=np.zeros(3), trend_shift_s=np.zeros(3),
                     body_relative=np.zeros((3, 4, 3)), other_body_relative=np.zeros((3, 4, 3)), wrist_sd_s=np.zeros(3))
    with pytest.raises(ValueError, match="shape"):
        risk_signals(spread_s=np.zeros(3), disagreement_s=np.zeros(4), evidence_s=np.zeros(3), own_s=np.zeros(3),
                     other_own_s=np.zeros(3), trend_sd_s=np.zeros(3), trend_shift_s=np.zeros(3),
                     body_relative=np.zeros((3, 4, 3)), other_body_relative=np.zeros((3, 4, 3)))


def test_risk_score_worked_and_checks_features():
    m = _one_feature_model(weight=2.0, mean=-3.0, scale=0.5)
    sig = _signals(spread=0.1)
    s = risk_score(m, sig, np.zeros(40, bool), 30.0)
    np.testing.assert_allclose(s, 2.0 * (np.log(0.1 + LOG_FLOOR_S) + 3.0) / 0.5)
    wrong = RiskModel(tuple(reversed(m.features)), m.mean, m.scale, m.weights, m.thresholds_s, m.offsets)
    with pytest.raises(ValueError, match="do not match"):
        risk_score(wrong, sig, np.zeros(40, bool), 30.0)


@pytest.mark.parametrize("wrist", [True, False])
def test_the_shipped_model_reads_the_codes_features(wrist):
    model = MODEL if wrist else MODEL_NO_WRIST
    assert model is not None, "benchmarks/fit_risk.py writes splicer/align/risk_model.py"
    assert model.features == feature_names(wrist=wrist)
    assert "seeds 0-3" in model.fitted_on  # fitted on the tuning seeds, never the held-out 100-104
    # monotone in the evidence (the fit's constraints): a signal in seconds raised by the same
    # factor everywhere moves its logarithm and every window of it by the same amount, and the
    # score by sum_j w_j / sd_j over them, held >= 0; its level's weight is >= 0
    names = feature_names(wrist=wrist)
    per_unit = model.weights / model.scale
    bases = ("spread", "disagreement", "evidence", "own", "other_own") + (("wrist_sd", "wrist_shift") if wrist else ())
    for base in bases:
        fam = [j for j, n in enumerate(names) if n == "log_" + base or n.startswith(f"log_{base}_")]
        assert len(fam) == 7 and per_unit[fam].sum() >= -1e-9, base
        assert model.weights[names.index(base + "_level")] >= 0.0
    unc = np.zeros(40, bool)
    for k in bases:
        lo, hi = _signals(spread=0.02, wrist=wrist), _signals(spread=0.02, wrist=wrist)
        lo[k], hi[k] = np.full(40, 0.01), np.full(40, 0.4)
        e_lo = error_quantile(model, risk_score(model, lo, unc, 30.0))
        e_hi = error_quantile(model, risk_score(model, hi, unc, 30.0))
        assert np.all(e_hi >= e_lo * (1 - 1e-9)), k


@pytest.fixture(scope="module")
def sample():
    return splice(MOTIONS / "sample_body.bvh", MOTIONS / "sample_hands.bvh", config=MOTIONS / "sample_sync.yaml")


def test_stage_on_the_sample(sample):
    """Both sides get the model's 98th percentile (RISK_QUANTILE); the rule it replaces is kept as evidence."""
    left, right = sample.sides["left"], sample.sides["right"]
    for r, o in ((left, right), (right, left)):
        conf = r.alignment.confidence
        assert conf.evidence_error_s is not None
        assert r.wrist is not None  # the wrist's refinement ran: the model that reads it
        sig = side_risk_signals(r, o)
        assert "wrist_sd" in sig
        unc = ~np.isfinite(r.hands_frame)
        est = error_quantile(MODEL, risk_score(MODEL, sig, unc, r.markers.spaces.body_fps), q=RISK_QUANTILE)
        cov = np.isfinite(conf.est_error_s)
        np.testing.assert_allclose(conf.est_error_s[cov], est[cov])  # nothing uncovered near: no edge floor
        np.testing.assert_allclose(conf.confidence[cov], 1 / (1 + (est[cov] / 0.1) ** 2))


def test_stage_leaves_what_it_cannot_read(sample):
    left, right = sample.sides["left"], sample.sides["right"]
    one = {"left": left}
    assert estimate_risk(one)["left"] is left  # one side: no other arm to compare
    alone = replace(right, alignment=replace(right.alignment, own=None))  # each arm its own pass 1
    out = estimate_risk({"left": left, "right": alone})
    assert out["left"] is left and out["right"] is alone
    unsmoothed = replace(right, trend=None)  # the trend stage has not run on this side
    out = estimate_risk({"left": left, "right": unsmoothed})
    assert out["right"] is unsmoothed
    np.testing.assert_array_equal(out["left"].alignment.confidence.est_error_s, left.alignment.confidence.est_error_s)


def test_stage_without_the_wrists_evidence(sample):
    """A side the wrist's refinement did not run on (placements that do not compare) is
    estimated by the model fitted without the wrist's signals."""
    left, right = sample.sides["left"], sample.sides["right"]
    plain = replace(right, wrist=None)
    out = estimate_risk({"left": left, "right": plain})
    sig = side_risk_signals(plain, left)
    assert "wrist_sd" not in sig
    unc = ~np.isfinite(plain.hands_frame)
    want = error_quantile(MODEL_NO_WRIST, risk_score(MODEL_NO_WRIST, sig, unc, plain.markers.spaces.body_fps),
                          q=RISK_QUANTILE)
    cov = np.isfinite(out["right"].alignment.confidence.est_error_s)
    assert cov.sum() > 100
    np.testing.assert_allclose(out["right"].alignment.confidence.est_error_s[cov], want[cov])
    with pytest.raises(ValueError, match="do not match"):
        risk_score(MODEL, sig, unc, plain.markers.spaces.body_fps)


def _load_fit():
    spec = importlib.util.spec_from_file_location("fit_risk", ROOT / "benchmarks" / "fit_risk.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_fit_recovers_a_known_ordinal_model():
    """Errors drawn from a known ordinal logistic model of two features: the fit finds its
    weights and offsets."""
    pytest.importorskip("scipy")
    fit = _load_fit().fit
    rng = np.random.default_rng(0)
    n = 40_000
    X = rng.normal(size=(n, 2)) * [1.0, 3.0] + [0.0, 5.0]
    w_true, th_true = np.array([1.5, -0.8]), np.array([0.0, 1.0, 2.5, 4.0])
    s = ((X - [0.0, 5.0]) / [1.0, 3.0]) @ w_true
    # P(err > t_k) = sigmoid(s - theta_k): draw the logistic latent and place it on the ladder
    latent = s + rng.logistic(size=n)
    ladder = np.array([0.05, 0.1, 0.2, 0.4])
    k = (latent[:, None] > th_true[None, :]).sum(1)  # rungs exceeded
    err = np.r_[0.02, ladder][k] * 1.01
    mu, sd, w, th = fit(X, err, ladder=ladder, l2=0.0)
    np.testing.assert_allclose(w, w_true, atol=0.05)
    np.testing.assert_allclose(th, th_true, atol=0.06)


def test_fit_script_keeps_the_seeds_asked_for(tmp_path):
    """``fit_risk.py --data`` on frames recorded over more seeds fits on the asked seeds only
    (their frame count is in the written model's ``fitted_on``), and the model it writes loads."""
    pytest.importorskip("scipy")
    mod = _load_fit()
    from splicer.align.risk import feature_names

    names = feature_names()
    d = len(names)
    rng = np.random.default_rng(1)
    seeds = np.repeat([0, 1, 2], [300, 500, 700])
    X = rng.normal(size=(len(seeds), d))
    X[300:400, [j for j, n in enumerate(names) if "wrist" in n]] = np.nan  # 100 frames of sides without the wrist's refinement
    E = np.exp(rng.normal(-3.0, 1.0, size=len(seeds)) + 0.5 * X[:, 0])  # errors of every rung
    data = tmp_path / "frames.npz"
    np.savez_compressed(data, X=X, E=E, takes=np.array(["synthetic"]), take=np.full(len(seeds), "synthetic"),
                        scenario=np.full(len(seeds), "base"), seed=seeds)
    out = tmp_path / "model.py"
    assert mod.main(["--seeds", "1", "--seed0", "1", "--data", str(data), "--out", str(out)]) == 0
    text = out.read_text()
    assert "seeds 1-1" in text
    spec = importlib.util.spec_from_file_location("splicer.align.fitted_model", out)  # its import is relative
    m = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(m)
    assert m.MODEL.features == feature_names() and m.MODEL_NO_WRIST.features == feature_names(wrist=False)
    assert "Fitted on 400 covered body frames" in m.MODEL.fitted_on  # the wrist's model: the frames that have it
    assert "Fitted on 500 covered body frames" in m.MODEL_NO_WRIST.fitted_on  # the other: every frame
