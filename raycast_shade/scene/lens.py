"""Where a camera's lens model folds: the part of the frame whose pixels have a ray.

The radial models of :mod:`raycast_shade.visibility.distortion` map an
undistorted radius ``r`` (OpenCV: ``r = |(x, y)|``; fisheye: the angle
``theta``) to a distorted one ``f(r) = r (1 + k1 r^2 + k2 r^4 + ...)``. From
``r = 0`` (where ``f' = 1``) ``f`` increases until ``f'`` first reaches zero,
the fold at ``r*``; no pixel whose distorted radius is ``f(r*)`` or more has
a direction inside the fold: the ray casting leaves it empty, or (where ``f``
turns negative past the fold, so that the Jacobian's determinant
``(f / r) f'`` is positive again) gives it a direction from past the fold,
on the opposite side of the axis. The fold is found in closed form, the roots of ``f'`` as a
polynomial in ``r^2``; the frame's share inside it on a grid of pixel
centres. Computed when a :class:`~raycast_shade.scene.camera.Camera` is made,
in NumPy, before any ray.

OpenCV's tangential terms ``p1, p2`` make the map not radial: no closed form. Then a
coarse grid of pixel centres (:data:`TANGENTIAL_GRID` a side) is undistorted as the
ray kernel does it (Newton's method from the distorted point, the kernel's stopping
rules and tolerance), and a centre counts as inside the fold when Newton converges
there and the Jacobian's determinant stays positive on the segment from the axis to
the solution (:data:`SEGMENT_SAMPLES` points): a solution reached only across a fold is
a direction from past it.
"""

from __future__ import annotations

import warnings

import numpy as np

from ..common.warnings import LensFoldWarning

__all__ = ["fold", "valid_fraction", "tangential_fraction", "warn_fold", "GRID", "TANGENTIAL_GRID",
           "SEGMENT_SAMPLES"]

GRID = 129  # pixel centres a side sampled for the valid fraction (every one of a smaller frame)
TANGENTIAL_GRID = 49  # ... and with tangential terms, each one undistorted by Newton (2,401 at most)
SEGMENT_SAMPLES = 24  # points on the way from the axis to a solution where the Jacobian must stay positive
# The ray kernel's Newton (visibility/distortion.py; scene/ may not import it): the same iteration
# cap, residual and step tolerance.
_ITERATIONS, _RESIDUAL, _STEP = 100, 1e-12, 1e-15


def fold(model: str, k) -> tuple | None:
    """The first fold of a radial lens model.

    Parameters
    ----------
    model : {"opencv", "fisheye"}
    k : sequence of float
        The camera's ``distortion``; for ``"opencv"`` the radial terms
        ``k1, k2, k3`` only (with tangential terms the map is not radial:
        None).

    Returns
    -------
    (r_star, f_star) or None
        The undistorted radius (fisheye: angle in radians) where ``f'`` first
        changes sign, and its distorted radius ``f(r*)``; None when ``f``
        increases over the whole domain (fisheye: up to 90 degrees).
    """
    k = [float(c) for c in k]
    if model == "opencv":
        if len(k) > 2 and (k[2] != 0.0 or k[3] != 0.0):
            return None
        radial = [k[0], k[1], k[4] if len(k) > 4 else 0.0]
        limit = np.inf
    else:
        radial = k[:4]
        limit = (0.5 * np.pi) ** 2  # the kernel refuses angles from 90 degrees on
    # f(r) = r (1 + sum_j c_j u^j), f'(r) = 1 + sum_j (2 j + 1) c_j u^j with u = r^2.
    deriv = np.array([1.0] + [(2 * j + 3) * c for j, c in enumerate(radial)])
    poly = deriv[:np.flatnonzero(deriv)[-1] + 1][::-1]  # highest power first
    if len(poly) < 2:
        return None
    with np.errstate(all="ignore"):  # a leading coefficient of 1e-300: roots beyond float64, no fold found
        try:
            roots = np.roots(poly)
        except np.linalg.LinAlgError:
            return None
        real = np.sort(roots[(np.abs(roots.imag) <= 1e-9 * np.abs(roots)) & (roots.real > 0.0)].real)
        # The first sign change, checked on the polynomial itself: f' > 0 from 0 to just before it
        # and < 0 just past it (a double root, where f' only touches 0, keeps f increasing).
        for u in real[np.isfinite(real) & (real < limit)]:
            before = np.linspace(0.0, u * (1.0 - 1e-6), 257)
            if np.polyval(poly, u * (1.0 + 1e-6)) < 0.0:
                if np.all(np.polyval(poly, before) > 0.0):
                    break
                return None  # an earlier sign change np.roots lost to rounding: no certain figure
        else:
            return None
    u = float(u)
    r = float(np.sqrt(u))
    return r, r * float(1.0 + sum(c * u ** (j + 1) for j, c in enumerate(radial)))


def _distorted_radii(camera, xs, ys):
    from .projection import intrinsics

    fx, fy, cx, cy = intrinsics(camera)
    return np.hypot((xs - cx) / fx, (ys - cy) / fy)


def valid_fraction(camera, f_star: float) -> float:
    """The share of the frame's pixel centres whose distorted radius is below ``f_star`` (a grid of
    at most :data:`GRID` x :data:`GRID` of them, the borders included)."""
    xs = np.linspace(0.0, camera.width - 1.0, min(camera.width, GRID))
    ys = np.linspace(0.0, camera.height - 1.0, min(camera.height, GRID))
    return float(np.mean(_distorted_radii(camera, xs[None, :], ys[:, None]) < f_star))


def _opencv(x, y, k):
    """OpenCV's distorted ``(x_d, y_d)`` of ``(x, y)`` and the Jacobian's determinant, term for term
    the ray kernel's ``_opencv_forward``."""
    k1, k2, p1, p2, k3 = k
    r2 = x * x + y * y
    s = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3))
    ds = k1 + r2 * (2.0 * k2 + 3.0 * k3 * r2)
    xd = x * s + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x)
    yd = y * s + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y
    off = 2.0 * x * y * ds + 2.0 * p1 * x + 2.0 * p2 * y
    a = s + 2.0 * x * x * ds + 2.0 * p1 * y + 6.0 * p2 * x
    d = s + 2.0 * y * y * ds + 6.0 * p1 * y + 2.0 * p2 * x
    return xd, yd, a * d - off * off, a, off, d


def _undistort_opencv(tx, ty, k):
    """The kernel's Newton on arrays of distorted points: the solutions ``(x, y)`` and whether each
    converged on the near side of any fold (the kernel's ``ok``)."""
    x, y = tx.copy(), ty.copy()
    live = np.ones(tx.shape, bool)
    with np.errstate(all="ignore"):  # diverging points overflow; they are dropped as the kernel drops them
        for _ in range(_ITERATIONS):
            if not live.any():
                break
            fx, fy, det, a, b, d = _opencv(x[live], y[live], k)
            ex, ey = fx - tx[live], fy - ty[live]
            go = (det > 0.0) & np.isfinite(ex + ey)
            sx = np.where(go, (d * ex - b * ey) / det, 0.0)
            sy = np.where(go, (a * ey - b * ex) / det, 0.0)
            xl, yl = x[live] - sx, y[live] - sy
            x[live], y[live] = xl, yl
            small = np.abs(sx) + np.abs(sy) <= _STEP * (1.0 + np.abs(xl) + np.abs(yl))
            idx = np.flatnonzero(live)
            live[idx[~go | small]] = False
        fx, fy, det, _, _, _ = _opencv(x, y, k)
        ok = (det > 0.0) & (np.abs(fx - tx) + np.abs(fy - ty) <= _RESIDUAL * (1.0 + np.abs(tx) + np.abs(ty)))
    return x, y, ok


def tangential_fraction(camera) -> float:
    """The share of a grid of pixel centres (:data:`TANGENTIAL_GRID` a side at most, the borders
    included) that the ray kernel gives a ray inside the fold, for OpenCV's model with any terms.

    A centre counts when Newton converges (the kernel's test) and the Jacobian's determinant is
    positive at :data:`SEGMENT_SAMPLES` points from the axis to the solution: sampled, so a fold
    thinner than the samples' spacing can be missed (an estimate, said as one)."""
    from .projection import intrinsics

    fx, fy, cx, cy = intrinsics(camera)
    k = np.zeros(5)
    k[:len(camera.distortion)] = camera.distortion
    xs = (np.linspace(0.0, camera.width - 1.0, min(camera.width, TANGENTIAL_GRID)) - cx) / fx
    ys = (np.linspace(0.0, camera.height - 1.0, min(camera.height, TANGENTIAL_GRID)) - cy) / fy
    tx, ty = (a.ravel() for a in np.meshgrid(xs, ys))
    x, y, ok = _undistort_opencv(tx, ty, k)
    s = np.linspace(0.0, 1.0, SEGMENT_SAMPLES)[1:-1, None]  # the ends: the axis (det 1) and ok's own test
    with np.errstate(all="ignore"):
        det = _opencv(s * x[ok], s * y[ok], k)[2]
    return float(np.count_nonzero(np.all(det > 0.0, axis=0)) / tx.size)


def _warn_tangential(camera) -> None:
    share = 100.0 * tangential_fraction(camera)
    if share >= 100.0:
        return
    n = min(camera.width, TANGENTIAL_GRID) * min(camera.height, TANGENTIAL_GRID)
    warnings.warn(f"camera.distortion: the opencv model {list(camera.distortion)} folds inside the frame: about "
                  f"{share:.3g}% of the frame's pixel centres have a ray inside the fold (estimated on {n} of them, "
                  "undistorted as the ray casting does; with tangential terms p1, p2 the fold has no closed "
                  "form); the others stay empty or see a direction from past the fold (a real lens's "
                  "coefficients keep the fold outside the image)", LensFoldWarning, stacklevel=6)


def warn_fold(camera) -> None:
    """A :class:`~raycast_shade.common.warnings.LensFoldWarning` when the lens folds inside the
    frame: some pixel centre (the farthest is a corner) lies beyond the fold's distorted radius
    (with OpenCV's tangential terms: some centre of a coarse grid has no ray inside the fold,
    :func:`tangential_fraction`)."""
    k = camera.distortion
    if camera.distortion_model == "opencv" and (k[2] != 0.0 or k[3] != 0.0):
        _warn_tangential(camera)
        return
    found = fold(camera.distortion_model, k)
    if found is None:
        return
    r_star, f_star = found
    w, h = camera.width - 1.0, camera.height - 1.0
    # Beyond f* by more than the kernel's residual (1e-12) can hide: certainly no ray inside the fold.
    if not _distorted_radii(camera, np.array([0.0, w, 0.0, w]), np.array([0.0, 0.0, h, h])).max() > f_star * (1 + 1e-6):
        return
    share = 100.0 * valid_fraction(camera, f_star)
    unit = " rad" if camera.distortion_model == "fisheye" else ""
    warnings.warn(f"camera.distortion: the {camera.distortion_model} model {list(camera.distortion)} folds at "
                  f"undistorted radius {r_star:.4g}{unit} (distorted {f_star:.4g}, normalised): about "
                  f"{share:.3g}% of the frame lies inside the fold; the pixels beyond it have no ray inside the "
                  "fold: they stay empty or see a direction from past it, across the axis (a real lens's "
                  "coefficients keep the fold outside the image)", LensFoldWarning,
                  stacklevel=5)
