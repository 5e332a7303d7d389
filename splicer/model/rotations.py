"""Quaternion helpers, vectorised over any leading axes.

Convention: unit quaternions stored scalar first, ``(w, x, y, z)``, as float64 arrays of
shape ``(..., 4)``.  A quaternion ``q`` maps a vector given in a joint's frame to its
parent's frame: ``v_parent = q * v_child * conj(q)``.  Euler angles follow BVH: an order
string such as ``"ZXY"`` lists the channels as they appear in the file and means the
intrinsic product ``R = Rz @ Rx @ Ry``.

Angles: **degrees at the API, radians inside.**  Every function here that takes or returns
an angle does so in degrees, as BVH files and reports do, and its parameter or function
name says so (``angles_deg``, ``quat_angle_deg``, ``yaw_quat_deg(angle_deg)``); radians appear
only inside the functions (and in internal arrays whose docstrings say so, such as a
marker heading).

>>> quat_from_euler([90.0, 0.0, 0.0], "XYZ").round(6).tolist()
[0.707107, 0.707107, 0.0, 0.0]
>>> round(float(quat_angle_deg(quat_from_euler([30.0, 0, 0], "XYZ"), [1.0, 0, 0, 0])), 9)
30.0
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "quat_from_euler",
    "euler_from_quat",
    "euler_channels_deg",
    "quat_mul",
    "quat_conj",
    "quat_twist",
    "quat_rotate",
    "quat_to_matrix",
    "quat_from_matrix",
    "quat_normalize",
    "quat_hemisphere",
    "quat_slerp",
    "quat_angle_deg",
    "quat_angle",
    "quat_median",
    "quat_between",
    "yaw_quat_deg",
    "atan2_stable",
    "cross3",
]


def atan2_stable(y: np.ndarray, x: np.ndarray) -> np.ndarray:
    """``np.arctan2(y, x)`` in radians, the same bits wherever ``y`` and ``x`` lie in memory.

    numpy 1.26 on AVX-512 machines computes ``arctan2`` of strided inputs (a column of a
    larger array) with results that differ in the last bit depending on the arrays'
    alignment, so the same angles came out 1 ULP apart from one call to the next (seen as a
    test comparing two identical computations exactly).  Contiguous inputs take one code
    path whatever the alignment; this passes contiguous copies.

    >>> float(atan2_stable(np.array([1.0]), np.array([1.0]))[0]) == np.pi / 4
    True
    >>> atan2_stable(np.float64(0.0), np.float64(-1.0)).shape  # one value stays one value
    ()
    """
    # asarray(order="C"), not ascontiguousarray: the latter turns a 0-d array (one rotation) into shape (1,)
    return np.arctan2(np.asarray(y, dtype=np.float64, order="C"), np.asarray(x, dtype=np.float64, order="C"))


def _flat(q: np.ndarray) -> tuple[np.ndarray, tuple[int, ...]]:
    q = np.asarray(q, dtype=np.float64)
    return q.reshape(-1, q.shape[-1]), q.shape[:-1]


def quat_from_euler(angles_deg: np.ndarray, order: str) -> np.ndarray:
    """Quaternions from intrinsic Euler angles in degrees.

    Parameters
    ----------
    angles_deg : np.ndarray [shape=(..., 3)]
        Angles in degrees, in the order of ``order``.
    order : str
        Three axis letters, e.g. ``"ZXY"`` (BVH channel order).

    Returns
    -------
    np.ndarray [shape=(..., 4), dtype=float64]
        ``(w, x, y, z)`` quaternions.
    """
    a = np.radians(np.asarray(angles_deg, dtype=np.float64))
    order = order.upper()
    if len(order) != a.shape[-1]:
        raise ValueError(f"order {order!r} does not match {a.shape[-1]} angles")
    q = np.zeros(a.shape[:-1] + (4,))
    if not order:
        q[..., 0] = 1.0
        return q
    # intrinsic: R = R_first @ R_second @ R_third.  Each factor turns about one axis, so the
    # product with it is written out without its zero terms: the same values, bit for bit, as
    # the Hamilton product with them (quat_mul), in about two thirds of the time on long takes.
    w, x, y, z = (q[..., k] for k in range(4))
    half = 0.5 * a[..., 0]
    w[...] = np.cos(half)
    q[..., 1 + "XYZ".index(order[0])] = np.sin(half)
    for k in range(1, len(order)):
        half = 0.5 * a[..., k]
        c, s = np.cos(half), np.sin(half)
        if order[k] == "X":
            w[...], x[...], y[...], z[...] = w * c - x * s, w * s + x * c, y * c + z * s, z * c - y * s
        elif order[k] == "Y":
            w[...], x[...], y[...], z[...] = w * c - y * s, x * c - z * s, w * s + y * c, z * c + x * s
        else:
            w[...], x[...], y[...], z[...] = w * c - z * s, x * c + y * s, y * c - x * s, w * s + z * c
    return q


def euler_from_quat(q: np.ndarray, order: str) -> np.ndarray:
    """Intrinsic Euler angles (degrees, in ``order``) of quaternions ``(..., 4)``.

    The inverse of :func:`quat_from_euler` for three distinct axes: with ``R = R_a R_b R_c``
    the middle angle is in [-90, 90] degrees; at gimbal lock (middle angle +-90) the last
    angle is set to 0 and the first carries the whole turn.

    Examples
    --------
    >>> q = quat_from_euler(np.array([30.0, -45.0, 100.0]), "ZXY")
    >>> np.round(euler_from_quat(q, "ZXY"), 6).tolist()
    [30.0, -45.0, 100.0]
    """
    order = order.upper()
    if len(order) != 3 or len(set(order)) != 3 or not set(order) <= set("XYZ"):
        raise ValueError(f"order must be three distinct axes of XYZ, not {order!r}")
    m = quat_to_matrix(quat_normalize(np.asarray(q, dtype=np.float64)))
    i, j, k = ("XYZ".index(c) for c in order)
    s = 1.0 if (i, j, k) in ((0, 1, 2), (1, 2, 0), (2, 0, 1)) else -1.0
    sb = np.clip(s * m[..., i, k], -1.0, 1.0)
    b = np.arcsin(sb)
    locked = np.abs(sb) > 1.0 - 1e-12
    a = np.where(locked, atan2_stable(s * m[..., k, j], m[..., j, j]), atan2_stable(-s * m[..., j, k], m[..., k, k]))
    c = np.where(locked, 0.0, atan2_stable(-s * m[..., i, j], m[..., i, i]))
    return np.degrees(np.stack([a, b, c], axis=-1)) + 0.0  # + 0.0: no negative zeros


def euler_channels_deg(q: np.ndarray, order: str, *, near_deg: np.ndarray | None = None) -> np.ndarray:
    """Euler angles to write as BVH rotation channels: the one Euler write-back of the package.

    Parameters
    ----------
    q : np.ndarray [shape=(T, 4)]
        One joint's rotations over time (normalised here).
    order : str
        The joint's channel order, e.g. ``"ZXY"``.
    near_deg : np.ndarray [shape=(T, 3)], optional
        Reference angles (degrees): each angle is moved by a multiple of 360 degrees to lie
        within 180 degrees of its reference (e.g. the linearly interpolated original channel).

    Returns
    -------
    np.ndarray [shape=(T, 3)]
        Degrees, unwrapped over time (no 360-degree jumps between frames).

    >>> q = quat_from_euler([[170.0, 0, 0], [-170.0, 0, 0]], "XYZ")
    >>> euler_channels_deg(q, "XYZ").round(6).tolist()
    [[170.0, 0.0, 0.0], [190.0, 0.0, 0.0]]
    """
    e = euler_from_quat(quat_normalize(q), order)
    e = np.degrees(np.unwrap(np.radians(e), axis=0))
    if near_deg is not None:
        e = e + 360.0 * np.round((np.asarray(near_deg, dtype=np.float64) - e) / 360.0)
    return e


def quat_mul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Hamilton product ``a * b`` (apply ``b`` first, then ``a``)."""
    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    aw, ax, ay, az = a[..., 0], a[..., 1], a[..., 2], a[..., 3]
    bw, bx, by, bz = b[..., 0], b[..., 1], b[..., 2], b[..., 3]
    out = np.empty(np.broadcast_shapes(a.shape[:-1], b.shape[:-1]) + (4,))
    out[..., 0] = aw * bw - ax * bx - ay * by - az * bz
    out[..., 1] = aw * bx + ax * bw + ay * bz - az * by
    out[..., 2] = aw * by - ax * bz + ay * bw + az * bx
    out[..., 3] = aw * bz + ax * by - ay * bx + az * bw
    return out


def quat_conj(q: np.ndarray) -> np.ndarray:
    """Conjugate (the inverse of a unit quaternion)."""
    q = np.asarray(q, dtype=np.float64)
    return q * np.array([1.0, -1.0, -1.0, -1.0])


def quat_rotate(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Rotate vectors ``v (..., 3)`` by unit quaternions ``q (..., 4)`` (broadcasting)."""
    q = np.asarray(q, dtype=np.float64)
    v = np.asarray(v, dtype=np.float64)
    w = q[..., :1]
    u = q[..., 1:]
    t = 2.0 * cross3(u, v)
    return v + w * t + cross3(u, t)


def cross3(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``np.cross`` of 3-vectors ``(..., 3)`` (broadcasting), the same numbers bit for bit, without
    its axis handling (a third of a warm run's rotations on small takes).

    >>> cross3(np.array([1.0, 0.0, 0.0]), np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 2.0]]))
    array([[ 0.,  0.,  1.],
           [ 0., -2.,  0.]])
    """
    a = np.asarray(a)
    b = np.asarray(b)
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    out = np.empty(np.broadcast_shapes(a.shape[:-1], b.shape[:-1]) + (3,), dtype=np.result_type(a, b))
    out[..., 0] = a1 * b2 - a2 * b1
    out[..., 1] = a2 * b0 - a0 * b2
    out[..., 2] = a0 * b1 - a1 * b0
    return out


def quat_to_matrix(q: np.ndarray) -> np.ndarray:
    """Rotation matrices ``(..., 3, 3)`` of unit quaternions ``(..., 4)``."""
    q = np.asarray(q, dtype=np.float64)
    w, x, y, z = np.moveaxis(q, -1, 0)
    m = np.empty(q.shape[:-1] + (3, 3))
    m[..., 0, 0] = 1 - 2 * (y * y + z * z)
    m[..., 0, 1] = 2 * (x * y - w * z)
    m[..., 0, 2] = 2 * (x * z + w * y)
    m[..., 1, 0] = 2 * (x * y + w * z)
    m[..., 1, 1] = 1 - 2 * (x * x + z * z)
    m[..., 1, 2] = 2 * (y * z - w * x)
    m[..., 2, 0] = 2 * (x * z - w * y)
    m[..., 2, 1] = 2 * (y * z + w * x)
    m[..., 2, 2] = 1 - 2 * (x * x + y * y)
    return m


def quat_from_matrix(m: np.ndarray) -> np.ndarray:
    """Unit quaternions ``(..., 4)`` of rotation matrices ``(..., 3, 3)`` (Shepperd's method).

    Each matrix is read through its largest of ``trace, m00, m11, m22``, so no division is
    ill-conditioned; the result has ``w >= 0``.  The zero matrix gives the identity; NaN or
    infinity raises ``ValueError`` (a degenerate frame upstream: callers must handle it first).

    Examples
    --------
    >>> quat_from_matrix(np.array([[0., -1, 0], [1, 0, 0], [0, 0, 1]])).round(6).tolist()  # 90 deg about Z
    [0.707107, 0.0, 0.0, 0.707107]
    """
    m = np.asarray(m, dtype=np.float64)
    if not np.all(np.isfinite(m)):
        raise ValueError("quat_from_matrix: the matrices contain NaN or infinity (a degenerate frame upstream)")
    m00, m01, m02 = m[..., 0, 0], m[..., 0, 1], m[..., 0, 2]
    m10, m11, m12 = m[..., 1, 0], m[..., 1, 1], m[..., 1, 2]
    m20, m21, m22 = m[..., 2, 0], m[..., 2, 1], m[..., 2, 2]
    tr = m00 + m11 + m22
    case = np.argmax(np.stack([tr, m00, m11, m22], axis=-1), axis=-1)
    with np.errstate(invalid="ignore", divide="ignore"):
        cand = np.stack([
            np.stack([1 + tr, m21 - m12, m02 - m20, m10 - m01], axis=-1),
            np.stack([m21 - m12, 1 + m00 - m11 - m22, m01 + m10, m02 + m20], axis=-1),
            np.stack([m02 - m20, m01 + m10, 1 - m00 + m11 - m22, m12 + m21], axis=-1),
            np.stack([m10 - m01, m02 + m20, m12 + m21, 1 - m00 - m11 + m22], axis=-1),
        ], axis=-2)
        q = np.take_along_axis(cand, case[..., None, None], axis=-2)[..., 0, :]
        q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    return np.where(q[..., :1] < 0, -q, q)


def quat_normalize(q: np.ndarray) -> np.ndarray:
    """Scale quaternions to unit length."""
    q = np.asarray(q, dtype=np.float64)
    return q / np.linalg.norm(q, axis=-1, keepdims=True)


def quat_twist(q: np.ndarray, axis: np.ndarray) -> np.ndarray:
    """The twist of rotations ``q`` about the unit vector ``axis`` (swing-twist decomposition:
    ``q = swing * twist``, the twist turning about ``axis`` only); the identity where ``q`` turns
    by 180 degrees about an axis perpendicular to ``axis`` (no twist defined).

    ``q`` is ``(..., 4)`` (w, x, y, z); ``axis`` ``(3,)`` in the frame ``q`` acts in.

    Examples
    --------
    >>> h = np.radians(30.0) / 2.0
    >>> q = np.array([np.cos(h), 0.0, 0.0, np.sin(h)])  # 30 degrees about z
    >>> np.allclose(quat_twist(q, np.array([0.0, 0.0, 1.0])), q), np.allclose(quat_twist(q, np.array([1.0, 0.0, 0.0])), [1, 0, 0, 0])
    (True, True)
    """
    q = np.asarray(q, dtype=np.float64)
    a = np.asarray(axis, dtype=np.float64)
    tw = np.concatenate([q[..., :1], (q[..., 1:] @ a)[..., None] * a], axis=-1)
    ok = np.linalg.norm(tw, axis=-1, keepdims=True) > 1e-12
    return quat_normalize(np.where(ok, tw, np.array([1.0, 0.0, 0.0, 0.0])))


def quat_hemisphere(q: np.ndarray, axis: int = 0) -> np.ndarray:
    """Flip signs along ``axis`` so consecutive quaternions have a non-negative dot product.

    ``q`` and ``-q`` are the same rotation; interpolation and averaging need a consistent
    choice.  ``axis`` is the time axis.
    """
    q = np.moveaxis(np.array(q, dtype=np.float64), axis, 0)
    if q.shape[0] > 1:
        dots = np.sum(q[1:] * q[:-1], axis=-1)
        flips = np.cumprod(np.where(dots < 0, -1.0, 1.0), axis=0)
        q[1:] *= flips[..., None]
    return np.moveaxis(q, 0, axis)


def quat_slerp(a: np.ndarray, b: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Spherical linear interpolation from ``a`` (t=0) to ``b`` (t=1), shortest arc.

    ``t`` broadcasts against ``a[..., 0]``.
    """
    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    t = np.asarray(t, dtype=np.float64)[..., None]
    dot = np.sum(a * b, axis=-1, keepdims=True)
    b = np.where(dot < 0, -b, b)
    dot = np.abs(dot)
    close = dot > 0.9995
    theta = np.arccos(np.clip(dot, -1.0, 1.0))
    s = np.sin(theta)
    s = np.where(close, 1.0, s)
    wa = np.where(close, 1.0 - t, np.sin((1.0 - t) * theta) / s)
    wb = np.where(close, t, np.sin(t * theta) / s)
    return quat_normalize(wa * a + wb * b)


def quat_angle_deg(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Geodesic angle between rotations, in degrees, in [0, 180].

    Computed as ``4 atan2(|a - b'|, |a + b'|)`` with ``b'`` the sign of ``b`` nearer ``a``:
    exact to rounding near 0 and near 180 degrees, where ``2 acos(|a . b|)`` loses half the
    digits.  ``a`` and ``b`` are unit quaternions ``(..., 4)`` (broadcasting).
    """
    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    b = np.where(np.sum(a * b, axis=-1, keepdims=True) < 0, -b, b)
    half = np.arctan2(np.linalg.norm(a - b, axis=-1), np.linalg.norm(a + b, axis=-1))
    return np.degrees(4.0 * half)


#: The same function under its old name (kept so code on other branches keeps working).
quat_angle = quat_angle_deg


def quat_median(q: np.ndarray, axis: int = 0) -> np.ndarray:
    """Rotation median: component-wise median of hemisphere-aligned quaternions, renormalised.

    Quaternions are aligned to the hemisphere of the first element along ``axis``.
    """
    q = np.moveaxis(np.asarray(q, dtype=np.float64), axis, 0)
    ref = q[0]
    sign = np.where(np.sum(q * ref, axis=-1, keepdims=True) < 0, -1.0, 1.0)
    return quat_normalize(np.median(q * sign, axis=0))


def quat_between(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Smallest rotation taking direction ``u`` onto direction ``v`` (both ``(..., 3)``).

    For opposite vectors the result is a half turn about an axis perpendicular to ``u``.
    """
    u = np.asarray(u, dtype=np.float64)
    v = np.asarray(v, dtype=np.float64)
    un = u / np.maximum(np.linalg.norm(u, axis=-1, keepdims=True), 1e-300)
    vn = v / np.maximum(np.linalg.norm(v, axis=-1, keepdims=True), 1e-300)
    w = 1.0 + np.sum(un * vn, axis=-1, keepdims=True)
    xyz = cross3(un, vn)
    q = np.concatenate([w, xyz], axis=-1)
    opposite = (w[..., 0] < 1e-9)
    if np.any(opposite):
        # any axis perpendicular to u
        alt = np.where(np.abs(un[..., :1]) < 0.9, np.array([1.0, 0, 0]), np.array([0, 1.0, 0]))
        perp = cross3(un, alt)
        perp /= np.linalg.norm(perp, axis=-1, keepdims=True)
        half = np.concatenate([np.zeros(perp.shape[:-1] + (1,)), perp], axis=-1)
        q = np.where(opposite[..., None], half, q)
    return quat_normalize(q)


def yaw_quat_deg(angle_deg: np.ndarray, up: int) -> np.ndarray:
    """Rotations by ``angle_deg`` (degrees) about the coordinate axis ``up`` (0=X, 1=Y, 2=Z)."""
    a = np.radians(np.asarray(angle_deg, dtype=np.float64))
    q = np.zeros(a.shape + (4,))
    q[..., 0] = np.cos(a / 2)
    q[..., 1 + up] = np.sin(a / 2)
    return q
