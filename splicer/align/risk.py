"""The alignment error's upper quantile per body frame, from the alignment's own evidence.

Each signal the alignment has about a body frame (the expected path's spread, how far each
arm's own path departs from the shared one, the sides' disagreement, how sure the time map's
smoother is and how far it moved the map, how fast the body's arms move, how near the frame
is to where the hands' material starts or stops, and, where the wrist's refinement ran
(:mod:`splicer.align.wrist`), how sure its offset is and how far it moved the map) says something about
whether the frame is off, and none says it alone: a wandering arm's path flags good frames,
a spread of zero misses a confidently wrong stretch.  :func:`error_quantile` weighs them
together with an ordinal logistic model fitted on the ground-truth protocol
(``benchmarks/fit_risk.py``, tuning seeds 0-3 of both takes, every scenario; the models in
:mod:`splicer.align.risk_model`: ``MODEL`` with the wrist's signals, ``MODEL_NO_WRIST`` the same fit
without them for a side the refinement did not run on)::

    P(error > t_k) = 1 / (1 + exp(-(s - theta_k)))       s = sum_j w_j (f_j - mu_j) / sigma_j

for a ladder of errors ``t_k`` (seconds) with one score ``s`` per frame.  The estimated error
is the error that the frame exceeds with probability ``1 - q``: ``theta(t) = s - logit(1 - q)``
solved for ``t``, ``log t`` linear in ``theta`` between the ladder's rungs (and beyond them,
with the end rungs' slopes).  With ``q = 0.98`` (:data:`splicer.defaults.RISK_QUANTILE`; 0.95
until 0.16.0) it is the estimated 98th percentile of the frame's error, and a frame is low
confidence when that exceeds 0.1 s.

The features (:func:`risk_features`) are the logarithms of the signals in seconds (``log(x +
1/120 s)``), the body arms' speeds relative to their root-mean-square, each also as its maximum
and its mean over centred windows of 0.25, 0.5 and 1 s, and the distance to the nearest
uncovered frame.  numpy alone: a run without ``--plot`` imports no scipy.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["RiskModel", "SIGNALS", "WRIST_SIGNALS", "WINDOWS_S", "risk_signals", "risk_features", "risk_score", "error_quantile",
           "running_max", "running_sum", "running_mean", "distance_to_uncovered"]

#: The per-frame signals the model reads, in order (:func:`risk_signals`): seconds, except the
#: speeds (relative to their take's root-mean-square).
SIGNALS = ("spread", "disagreement", "evidence", "own", "other_own", "trend_sd", "trend_shift", "speed", "other_speed",
           "min_speed", "wrist_sd", "wrist_shift")
#: Signals a side has only where the wrist's refinement ran (:mod:`splicer.align.wrist`); a model
#: is fitted with them and one without (:mod:`splicer.align.risk_model`).
WRIST_SIGNALS = ("wrist_sd", "wrist_shift")
#: Signals entered as ``log(x + LOG_FLOOR_S)``.
LOG_SIGNALS = frozenset({"spread", "disagreement", "evidence", "own", "other_own", "trend_sd", "trend_shift",
                         "wrist_sd", "wrist_shift"})
#: Added to a seconds signal before its logarithm (a quarter of a 30 fps frame).
LOG_FLOOR_S = 1.0 / 120.0
#: Each signal also enters as its maximum and its mean over centred windows of these lengths.
WINDOWS_S = (0.25, 0.5, 1.0)
#: The distance to the nearest uncovered frame is capped here, seconds.
EDGE_CAP_S = 2.0
#: Each seconds signal also enters as its level: its mean over the longest window, in seconds,
#: capped here.
LEVEL_CAP_S = 2.0


@dataclass(frozen=True, eq=False)
class RiskModel:
    """An ordinal logistic model of a frame's alignment error.

    Attributes
    ----------
    features : tuple of str
        Feature names, in the order of :func:`risk_features`.
    mean, scale : np.ndarray [shape=(d,)]
        Standardisation of each feature (``scale > 0``).
    weights : np.ndarray [shape=(d,)]
        Weight of each standardised feature in the score ``s``.
    thresholds_s : np.ndarray [shape=(K,)]
        The ladder of errors ``t_k``, seconds, increasing.
    offsets : np.ndarray [shape=(K,)]
        ``theta_k``, increasing: ``P(error > t_k) = sigmoid(s - theta_k)``.
    fitted_on : str
        What the model was fitted on.
    """

    features: tuple
    mean: np.ndarray
    scale: np.ndarray
    weights: np.ndarray
    thresholds_s: np.ndarray
    offsets: np.ndarray
    fitted_on: str = ""

    def __post_init__(self):
        d = len(self.features)
        for name in ("mean", "scale", "weights"):
            a = np.asarray(getattr(self, name), dtype=np.float64)
            if a.shape != (d,) or not np.all(np.isfinite(a)):
                raise ValueError(f"RiskModel.{name} must be {d} finite numbers, got shape {a.shape}")
            object.__setattr__(self, name, a)
        if not np.all(self.scale > 0):
            raise ValueError("RiskModel.scale must be positive")
        t = np.asarray(self.thresholds_s, dtype=np.float64)
        th = np.asarray(self.offsets, dtype=np.float64)
        if t.ndim != 1 or len(t) < 2 or th.shape != t.shape or not (np.all(np.diff(t) > 0) and np.all(t > 0)):
            raise ValueError("RiskModel.thresholds_s must be at least two positive, increasing errors, "
                             "with one offset each")
        if not (np.all(np.isfinite(th)) and np.all(np.diff(th) > 0)):
            raise ValueError("RiskModel.offsets must be finite and increasing (a larger error is less likely)")
        object.__setattr__(self, "thresholds_s", t)
        object.__setattr__(self, "offsets", th)

    def probability_above(self, score: np.ndarray, error_s: float) -> np.ndarray:
        """``P(error > error_s)`` per frame, ``error_s`` one of :attr:`thresholds_s`."""
        k = np.flatnonzero(np.isclose(self.thresholds_s, error_s))
        if len(k) != 1:
            raise ValueError(f"error_s must be one of the model's thresholds {self.thresholds_s.tolist()}, got {error_s!r}")
        return 1.0 / (1.0 + np.exp(-(np.asarray(score, dtype=np.float64) - self.offsets[k[0]])))


def running_max(x: np.ndarray, half: int) -> np.ndarray:
    """Maximum of ``x[i - half : i + half + 1]`` (clipped to the array) per ``i``.

    >>> running_max(np.array([0.0, 3.0, 1.0, 0.0, 0.0, 2.0]), 1).tolist()
    [3.0, 3.0, 3.0, 1.0, 2.0, 2.0]
    """
    x = np.asarray(x, dtype=np.float64)
    if half <= 0 or len(x) == 0:
        return x.copy()
    p = np.pad(x, half, mode="edge")  # the edge value repeated: the maximum over the clipped window
    return np.lib.stride_tricks.sliding_window_view(p, 2 * half + 1).max(axis=1)


def _window_edges(n: int, half: int) -> tuple[np.ndarray, np.ndarray]:
    i = np.arange(n)
    return np.maximum(i - half, 0), np.minimum(i + half + 1, n)


def running_sum(x: np.ndarray, half: int) -> np.ndarray:
    """Sum of ``x[i - half : i + half + 1]`` (clipped to the array) per ``i``, along the first
    axis (any trailing shape), from one running sum.

    >>> running_sum(np.array([0.0, 3.0, 0.0, 0.0]), 1).tolist()
    [3.0, 3.0, 3.0, 0.0]
    """
    x = np.asarray(x, dtype=np.float64)
    n = len(x)
    if half <= 0 or n == 0:
        return x.copy()
    c = np.concatenate([np.zeros((1,) + x.shape[1:]), np.cumsum(x, axis=0)])
    lo, hi = _window_edges(n, half)
    return c[hi] - c[lo]


def running_mean(x: np.ndarray, half: int) -> np.ndarray:
    """Mean of ``x[i - half : i + half + 1]`` (clipped to the array) per ``i``.

    >>> running_mean(np.array([0.0, 3.0, 0.0, 0.0]), 1).tolist()
    [1.5, 1.0, 1.0, 0.0]
    """
    total = running_sum(x, half)
    if half <= 0 or len(total) == 0:
        return total
    lo, hi = _window_edges(len(total), half)
    return total / (hi - lo)


def distance_to_uncovered(uncovered: np.ndarray) -> np.ndarray:
    """Frames from each frame to the nearest uncovered one (``inf`` when none is).

    >>> distance_to_uncovered(np.array([True, False, False, False, True, False])).tolist()
    [0.0, 1.0, 2.0, 1.0, 0.0, 1.0]
    """
    u = np.asarray(uncovered, dtype=bool)
    n = len(u)
    idx = np.arange(n, dtype=np.float64)
    last = np.maximum.accumulate(np.where(u, idx, -np.inf)) if n else idx
    nxt = np.minimum.accumulate(np.where(u, idx, np.inf)[::-1])[::-1] if n else idx
    return np.minimum(idx - last, nxt - idx)


def _speed(relative: np.ndarray) -> np.ndarray:
    """Summed speed of the markers, frames (T, M, 3) -> (T,), relative to its root-mean-square."""
    r = np.nan_to_num(np.asarray(relative, dtype=np.float64))
    if r.shape[0] < 2:
        return np.zeros(r.shape[0])
    v = np.linalg.norm(np.gradient(r, axis=0), axis=-1)
    v = v.reshape(len(v), -1).sum(axis=1)
    rms = float(np.sqrt(np.mean(v ** 2)))
    return v / rms if rms > 0 else np.zeros_like(v)


def risk_signals(*, spread_s, disagreement_s, evidence_s, own_s, other_own_s, trend_sd_s, trend_shift_s,
                 body_relative, other_body_relative, speeds=None, wrist_sd_s=None, wrist_shift_s=None) -> dict:
    """The model's per-frame signals (:data:`SIGNALS`) of one side.

    Parameters
    ----------
    spread_s : np.ndarray [shape=(n,)]
        The expected path's spread, seconds.
    disagreement_s : np.ndarray [shape=(n,)]
        How far the two sides (or the arms' own paths) disagree, seconds.
    evidence_s : np.ndarray [shape=(n,)]
        The estimated error from those alone (their larger, with any floor), seconds.
    own_s, other_own_s : np.ndarray [shape=(n,)]
        Seconds between the shared expected path and this arm's own path, the other arm's.
    trend_sd_s, trend_shift_s : np.ndarray [shape=(n,)]
        The time map's smoother (:class:`splicer.transfer.trend.TrendFit`): the standard
        deviation of the hands time it gives, and how far it moved the map, seconds.
    body_relative, other_body_relative : np.ndarray [shape=(n, M, 3)]
        The body's markers of this arm and of the other, relative to their shoulder.
    speeds : tuple of np.ndarray, optional
        ``(speed, other_speed)`` already computed from those markers (the other side's signals,
        swapped): then the markers are not read again.
    wrist_sd_s, wrist_shift_s : np.ndarray [shape=(n,)], optional
        The wrist's refinement (:class:`splicer.align.wrist.WristEvidence`): its offset
        posterior's standard deviation and how far it moved the map, seconds.  Both or neither.

    Returns
    -------
    dict of str -> np.ndarray [shape=(n,)]
        NaN (uncovered, or not measured) becomes 0.  The wrist's signals only when given.
    """
    s = {"spread": spread_s, "disagreement": disagreement_s, "evidence": evidence_s, "own": own_s,
         "other_own": other_own_s, "trend_sd": trend_sd_s, "trend_shift": trend_shift_s}
    if (wrist_sd_s is None) != (wrist_shift_s is None):
        raise ValueError("give both wrist signals or neither")
    if wrist_sd_s is not None:
        s["wrist_sd"], s["wrist_shift"] = wrist_sd_s, wrist_shift_s
    out = {k: np.nan_to_num(np.asarray(v, dtype=np.float64), nan=0.0, posinf=0.0) for k, v in s.items()}
    n = len(out["spread"])
    for k, v in out.items():
        if v.shape != (n,):
            raise ValueError(f"{k} must have shape ({n},), got {v.shape}")
    if speeds is None:
        speeds = (_speed(body_relative), _speed(other_body_relative))
    out["speed"], out["other_speed"] = (np.asarray(v, dtype=np.float64) for v in speeds)
    if out["speed"].shape != (n,) or out["other_speed"].shape != (n,):
        raise ValueError(f"the body markers must have {n} frames")
    out["min_speed"] = np.minimum(out["speed"], out["other_speed"])
    return out


def risk_features(signals: dict, uncovered: np.ndarray, fps: float):
    """Yield ``(name, feature)`` pairs (each shape (n,)) in the model's order.

    Each signal of :data:`SIGNALS` that ``signals`` holds (every one but the wrist's, which
    only a side the wrist's refinement ran on has; logarithm for the ones in seconds), then its
    maximum and its mean over centred windows of :data:`WINDOWS_S`; then the level of each
    seconds signal (its mean over the longest window, seconds, at most :data:`LEVEL_CAP_S`);
    then ``edge`` (seconds to the nearest uncovered frame, at most :data:`EDGE_CAP_S`) and
    ``edge_in`` (1 within :data:`splicer.defaults.COVERAGE_EDGE_S` of one, counted in whole
    frames as :func:`splicer.stages.coverage.coverage_edges` does).
    """
    from ..defaults import COVERAGE_EDGE_S

    if not (fps > 0 and np.isfinite(fps)):
        raise ValueError(f"fps must be positive and finite, got {fps!r}")
    missing = [k for k in SIGNALS if k not in signals and k not in WRIST_SIGNALS]
    if missing or (("wrist_sd" in signals) != ("wrist_shift" in signals)):
        raise ValueError(f"signals missing: {missing or list(WRIST_SIGNALS)}")
    present = tuple(k for k in SIGNALS if k in signals)
    for name in present:
        x = np.asarray(signals[name], dtype=np.float64)
        if name in LOG_SIGNALS:
            x, name = np.log(np.maximum(x, 0.0) + LOG_FLOOR_S), "log_" + name
        yield name, x
        for w in WINDOWS_S:
            half = max(1, int(round(w * fps / 2)))
            yield f"{name}_max{w:g}", running_max(x, half)
            yield f"{name}_mean{w:g}", running_mean(x, half)
    half = max(1, int(round(WINDOWS_S[-1] * fps / 2)))
    for name in present:
        if name in LOG_SIGNALS:  # the level in seconds, where the logarithm flattens what is far too large
            x = np.maximum(np.asarray(signals[name], dtype=np.float64), 0.0)
            yield f"{name}_level", np.minimum(running_mean(x, half), LEVEL_CAP_S)
    d = distance_to_uncovered(uncovered)
    yield "edge", np.minimum(d / float(fps), EDGE_CAP_S)
    yield "edge_in", (d <= round(COVERAGE_EDGE_S * fps)).astype(np.float64)  # as stages.coverage counts


def feature_names(wrist: bool = True) -> tuple:
    """The names :func:`risk_features` yields, in order, with the wrist's signals or without."""
    sig = {k: np.zeros(2) for k in SIGNALS if wrist or k not in WRIST_SIGNALS}
    return tuple(name for name, _ in risk_features(sig, np.zeros(2, dtype=bool), 30.0))


def risk_score(model: RiskModel, signals: dict, uncovered: np.ndarray, fps: float) -> np.ndarray:
    """The model's score ``s`` per frame (one feature at a time: O(n) memory)."""
    s = None
    for j, (name, f) in enumerate(risk_features(signals, uncovered, fps)):
        if j >= len(model.features) or model.features[j] != name:
            raise ValueError(f"the risk model's features do not match the code's: feature {j} is {name!r}")
        term = model.weights[j] * ((f - model.mean[j]) / model.scale[j])
        s = term if s is None else s + term
    if s is None or j + 1 != len(model.features):
        raise ValueError("the risk model's features do not match the code's")
    return s


def error_quantile(model: RiskModel, score: np.ndarray, q: float = 0.95, max_s: float = 60.0) -> np.ndarray:
    """The error each frame exceeds with probability ``1 - q``, seconds (the ``q`` quantile).

    ``P(error > t) = sigmoid(score - theta(t))`` with ``theta`` linear in ``log t`` between the
    model's rungs (and beyond them, with the end rungs' slopes); the result is clipped to
    ``[0, max_s]``.

    Examples
    --------
    >>> m = RiskModel(("x",), [0.0], [1.0], [1.0], [0.05, 0.1, 0.2], [1.0, 2.0, 3.0])
    >>> e = error_quantile(m, np.array([2.0 + np.log(0.05 / 0.95)]), q=0.95)  # P(error > 0.1 s) = 0.05
    >>> round(float(e[0]), 6)
    0.1
    >>> round(float(error_quantile(m, np.array([4.0]), q=0.5)[0]), 6)  # one rung's step past 0.2 s
    0.4
    """
    if not (0.0 < q < 1.0):
        raise ValueError(f"q must lie in (0, 1), got {q!r}")
    a = 1.0 - q
    theta = np.asarray(score, dtype=np.float64) - np.log(a / (1.0 - a))
    th, lt = model.offsets, np.log(model.thresholds_s)
    lo = lt[0] + (theta - th[0]) * (lt[1] - lt[0]) / (th[1] - th[0])
    hi = lt[-1] + (theta - th[-1]) * (lt[-1] - lt[-2]) / (th[-1] - th[-2])
    logt = np.where(theta < th[0], lo, np.where(theta > th[-1], hi, np.interp(theta, th, lt)))
    return np.clip(np.exp(np.minimum(logt, np.log(max_s) + 1.0)), 0.0, max_s)
