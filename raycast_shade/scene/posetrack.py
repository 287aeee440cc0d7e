"""Pose tracks: one rigid model-to-world pose per view, for objects that move through a view set.

A pose track is a ``(V, 4, 4)`` float64 array, view ``i``'s
:attr:`~raycast_shade.scene.scene.Model.pose` (``x_world = R x_model + t``), the
form BOP's per-image ``cam_R_m2c``/``cam_t_m2c`` and Kubric's per-frame object
poses take. :func:`keyframes` interpolates one between key views (rotation by
spherical linear interpolation of unit quaternions, translation linearly, held
beyond the first and last key), :func:`orbit_poses` turns a pose about an axis
across the views, and :func:`check_pose_track` checks a given one
(:func:`raycast_shade.render_views`' ``poses``).
"""

from __future__ import annotations

import numpy as np

from ..common.validate import as_array, as_count, as_scalar, as_vec3

__all__ = ["keyframes", "orbit_poses", "check_pose_track", "POSE_TOLERANCE"]

POSE_TOLERANCE = 1e-9  # R R^T off the identity by at most this: Model.pose's own tolerance


def check_pose_track(value, name: str, n_views: int) -> np.ndarray:
    """``value`` as a read-only ``(n_views, 4, 4)`` float64 array of rigid poses, or raise naming ``name``.

    Raises
    ------
    TypeError, ValueError
        Naming ``name`` (and the view): another shape or count, a last row other than
        ``[0, 0, 0, 1]``, a 3x3 part that is not a rotation (orthonormal to
        :data:`POSE_TOLERANCE`, determinant +1).
    """
    P = as_array(value, name, dtype=np.float64, copy=True)
    if P.ndim != 3 or P.shape[1:] != (4, 4):
        raise ValueError(f"{name}: expected a (V, 4, 4) array of poses, one per view, got shape {P.shape}")
    if len(P) != n_views:
        raise ValueError(f"{name}: expected one pose per view ({n_views}), got {len(P)}")
    bottom = np.all(P[:, 3] == [0.0, 0.0, 0.0, 1.0], axis=1)
    if not bottom.all():
        i = int(np.argmin(bottom))
        raise ValueError(f"{name}[{i}]: last row must be [0, 0, 0, 1], got {P[i, 3].tolist()}")
    R = P[:, :3, :3]
    err = np.abs(R @ R.transpose(0, 2, 1) - np.eye(3)).max(axis=(1, 2))
    det = np.linalg.det(R)
    bad = (err > POSE_TOLERANCE) | (det < 0)
    if bad.any():
        i = int(np.argmax(bad))
        raise ValueError(f"{name}[{i}]: its 3x3 part must be a rotation (orthonormal to {POSE_TOLERANCE:g}, "
                         f"determinant +1); got R R^T off the identity by {err[i]:.3g}, determinant {det[i]:.6g}")
    P.setflags(write=False)
    return P


def _quaternions(R) -> np.ndarray:
    """(K, 4) unit quaternions ``(w, x, y, z)`` of (K, 3, 3) rotations (Shepperd's branch by the largest term)."""
    q = np.empty((len(R), 4))
    for k, m in enumerate(R):
        tr = np.trace(m)
        terms = [tr, m[0, 0], m[1, 1], m[2, 2]]
        i = int(np.argmax(terms))
        if i == 0:
            s = 2.0 * np.sqrt(1.0 + tr)
            q[k] = [0.25 * s, (m[2, 1] - m[1, 2]) / s, (m[0, 2] - m[2, 0]) / s, (m[1, 0] - m[0, 1]) / s]
        else:
            a, b, c = i - 1, i % 3, (i + 1) % 3  # the axis with the largest diagonal term, then the next two
            s = 2.0 * np.sqrt(1.0 + m[a, a] - m[b, b] - m[c, c])
            v = np.empty(3)
            v[a], v[b], v[c] = 0.25 * s, (m[b, a] + m[a, b]) / s, (m[c, a] + m[a, c]) / s
            q[k] = [(m[c, b] - m[b, c]) / s, *v]
    return q / np.linalg.norm(q, axis=1, keepdims=True)


def _matrices(q) -> np.ndarray:
    """(N, 3, 3) rotations of (N, 4) unit quaternions ``(w, x, y, z)``."""
    w, x, y, z = q.T
    return np.stack([np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], -1),
                     np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], -1),
                     np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], -1)], 1)


def _slerp(q0, q1, s) -> np.ndarray:
    """(N, 4) quaternions along the shorter arc from ``q0`` to ``q1`` (rows) at fractions ``s`` (N,)."""
    d = np.einsum("ij,ij->i", q0, q1)
    q1 = np.where(d[:, None] < 0, -q1, q1)  # q and -q are one rotation: take the shorter way
    d = np.abs(d)
    theta = np.arccos(np.clip(d, -1.0, 1.0))
    sin = np.sin(theta)
    near = sin < 1e-12  # (almost) the same rotation: linear, then normalised
    safe = np.where(near, 1.0, sin)
    a = np.where(near, 1.0 - s, np.sin((1.0 - s) * theta) / safe)
    b = np.where(near, s, np.sin(s * theta) / safe)
    q = a[:, None] * q0 + b[:, None] * q1
    return q / np.linalg.norm(q, axis=1, keepdims=True)


def keyframes(views, poses, n_views) -> np.ndarray:
    """A pose track through key poses: slerp between keys, linear translation, held beyond the ends.

    Parameters
    ----------
    views : (K,) int
        The key views, strictly increasing, ``>= 0``.
    poses : (K, 4, 4) float
        The rigid model-to-world pose at each key view.
    n_views : int
        Views in the track (``>= 1``); keys at or beyond it are allowed (the track is cut).

    Returns
    -------
    (n_views, 4, 4) float64
        View ``i`` between keys ``a <= i <= b``: rotation ``slerp(R_a, R_b, s)`` (the shorter arc) and
        translation ``(1 - s) t_a + s t_b``, ``s = (i - a) / (b - a)``; the first key's pose before it,
        the last's after it. A key view's pose is its key, bit for bit.

    Raises
    ------
    TypeError, ValueError
        Naming the argument: keys not increasing, a count mismatch, a pose that is not rigid.
    """
    n_views = as_count(n_views, "n_views")
    keys = as_array(views, "views", dtype=np.int64, ndim=1)
    if np.ndim(views) != 1 or len(keys) == 0:
        raise ValueError(f"views: expected a sequence of at least one key view, got {views!r:.40}")
    if keys[0] < 0 or np.any(np.diff(keys) <= 0):
        raise ValueError(f"views: expected strictly increasing view indices >= 0, got {keys.tolist()}")
    P = check_pose_track(poses, "poses", len(keys))
    q = _quaternions(P[:, :3, :3])
    out = np.empty((n_views, 4, 4))
    out[:] = np.eye(4)
    i = np.arange(n_views)
    b = np.clip(np.searchsorted(keys, i, side="right"), 1, len(keys) - 1) if len(keys) > 1 else np.zeros(n_views, int)
    a = np.maximum(b - 1, 0)
    span = np.where(keys[b] > keys[a], keys[b] - keys[a], 1)
    s = np.clip((i - keys[a]) / span, 0.0, 1.0)
    out[:, :3, :3] = _matrices(_slerp(q[a], q[b], s))
    out[:, :3, 3] = (1.0 - s)[:, None] * P[a, :3, 3] + s[:, None] * P[b, :3, 3]
    exact = np.searchsorted(keys, i)
    hit = (exact < len(keys)) & (keys[np.minimum(exact, len(keys) - 1)] == i)
    out[hit] = P[exact[hit]]  # keys exactly (slerp at s = 0 or 1 rounds)
    out[i < keys[0]] = P[0]
    out[i > keys[-1]] = P[-1]
    return out


def _axis_angle(axis, angle) -> np.ndarray:
    """(N, 3, 3) rotations by ``angle`` (N,) radians about the unit ``axis`` (Rodrigues)."""
    k = np.array([[0.0, -axis[2], axis[1]], [axis[2], 0.0, -axis[0]], [-axis[1], axis[0], 0.0]])
    s, c = np.sin(angle)[:, None, None], np.cos(angle)[:, None, None]
    return np.eye(3) + s * k + (1.0 - c) * (k @ k)


def orbit_poses(n_views, axis=(0.0, 1.0, 0.0), degrees=360.0, *, center=(0.0, 0.0, 0.0), start=None) -> np.ndarray:
    """A pose track turning a model about an axis: view ``i`` turned by ``i * degrees / n_views``.

    Parameters
    ----------
    n_views : int
        Views in the track (``>= 1``).
    axis : (3,) float
        The axis direction (normalised; right-handed turn).
    degrees : float
        The turn across the views (360: one turn, the last view one step short of the first,
        as :func:`~raycast_shade.apps.animate.orbit_cameras` places cameras); negative turns the other way.
    center : (3,) float
        A world point on the axis.
    start : (4, 4) float, optional
        The model's pose at view 0 (default: the identity); the turn applies after it.

    Returns
    -------
    (n_views, 4, 4) float64
        ``T(c) Rot(axis, i * degrees / n_views) T(-c) start``.
    """
    n_views = as_count(n_views, "n_views")
    axis = as_vec3(axis, "axis", nonzero=True)
    axis = axis / np.linalg.norm(axis)
    degrees = as_scalar(degrees, "degrees", minimum=-1e6, maximum=1e6)
    c = as_vec3(center, "center")
    S = np.eye(4) if start is None else check_pose_track(np.asarray(start)[None] if np.ndim(start) == 2 else start,
                                                         "start", 1)[0]
    R = _axis_angle(axis, np.radians(degrees) * np.arange(n_views) / n_views)
    out = np.zeros((n_views, 4, 4))
    out[:, :3, :3] = R @ S[:3, :3]
    out[:, :3, 3] = (R @ (S[:3, 3] - c)) + c
    out[:, 3, 3] = 1.0
    return out
