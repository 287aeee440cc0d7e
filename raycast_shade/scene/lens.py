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
"""

from __future__ import annotations

import warnings

import numpy as np

from ..common.warnings import LensFoldWarning

__all__ = ["fold", "valid_fraction", "warn_fold", "GRID"]

GRID = 129  # pixel centres a side sampled for the valid fraction (every one of a smaller frame)


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


def warn_fold(camera) -> None:
    """A :class:`~raycast_shade.common.warnings.LensFoldWarning` when the lens folds inside the
    frame: some pixel centre (the farthest is a corner) lies beyond the fold's distorted radius."""
    found = fold(camera.distortion_model, camera.distortion)
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
