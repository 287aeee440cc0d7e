"""Image accuracy metrics against a ground truth.

Every error below is measured on the pixels *both* images cover; pixels that
only one of them covers (a tessellation's silhouette is not the surface's)
are counted apart, as the silhouette mismatch, and never enter an error.

=================  ==========================================================
``rmse``           root mean square error of the linear RGB image
``rmse_interior``  the same, without the pixels within ``rim`` (2) pixels of
                   the common silhouette: there a ray meets the tessellation
                   far from where it meets the surface, a geometric error
                   that no shading method can remove
``psnr``           ``10 log10(peak^2 / mse)`` in dB (scikit-image), ``peak``
                   the reference's maximum over the common pixels; ``inf``
                   for identical images
``max_error``      largest absolute channel difference
``ssim``           mean structural similarity (scikit-image) over the common
                   pixels, both images zeroed outside them
``mean_angle``     mean angle between the normals, degrees
``p95_angle``      95th percentile of that angle, degrees
``highlight``      distance in pixels between the highlights: each is the
                   intensity-weighted centroid of the brightest pixels
``flip``           mean FLIP (NVIDIA's perceptual difference, HDR mode) over
                   the common pixels; optional
``only_ref``       pixels covered by the reference only
``only_test``      pixels covered by the test image only
=================  ==========================================================

PSNR and SSIM come from :mod:`skimage.metrics` and FLIP from the
``flip-evaluator`` package; both are optional dependencies (``pip install
'raycast_shade[bench]'``), and asking for a metric whose package is missing
raises :class:`MissingExtraError` with that instruction.

>>> import numpy as np
>>> from raycast_shade.study.metrics import rmse
>>> a = np.zeros((4, 4, 3)); b = a + 0.5
>>> float(rmse(a, b))
0.5
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np

from ..common.extras import MissingExtraError, require

__all__ = [
    "MissingExtraError", "Comparison", "compare", "common_mask", "rmse", "psnr", "max_error", "ssim",
    "normal_angles", "highlight_position", "flip", "silhouette_mismatch", "interior_mask", "angular_step",
    "convergence_order",
]


def _require(module: str, package: str, what: str):
    return require(module, package, what, "bench")


def _image(x, name):
    a = np.asarray(getattr(x, "image", x), np.float64)
    if a.ndim == 2:
        a = a[..., None]
    if a.ndim != 3:
        raise ValueError(f"{name}: expected an (H, W, C) or (H, W) image, got shape {a.shape}")
    return a


def _mask(x, image, name):
    m = getattr(x, "mask", None)
    if m is None:
        return np.ones(image.shape[:2], bool)
    m = np.asarray(m, bool)
    if m.shape != image.shape[:2]:
        raise ValueError(f"{name}.mask: expected shape {image.shape[:2]}, got {m.shape}")
    return m


def common_mask(mask_ref, mask_test) -> np.ndarray:
    """(H, W) bool: pixels both images cover."""
    mask_ref = np.asarray(mask_ref, bool)
    mask_test = np.asarray(mask_test, bool)
    if mask_ref.shape != mask_test.shape:
        raise ValueError(f"masks: shapes differ, {mask_ref.shape} and {mask_test.shape}")
    return mask_ref & mask_test


def _pair(ref, test, mask):
    ref = np.asarray(ref, np.float64)
    test = np.asarray(test, np.float64)
    if ref.shape != test.shape:
        raise ValueError(f"images: shapes differ, {ref.shape} and {test.shape}")
    if mask is None:
        return ref.reshape(-1), test.reshape(-1)
    mask = np.asarray(mask, bool)
    if mask.shape != ref.shape[: mask.ndim]:
        raise ValueError(f"mask: shape {mask.shape} does not match the images' {ref.shape}")
    return ref[mask].reshape(-1), test[mask].reshape(-1)


def rmse(ref, test, mask=None) -> float:
    """Root mean square error.

    Parameters
    ----------
    ref, test : (H, W, C) or (H, W) float
    mask : (H, W) bool, optional
        Pixels to compare (all when omitted).

    Returns
    -------
    float
        NaN when the mask is empty.
    """
    a, b = _pair(ref, test, mask)
    if a.size == 0:
        return math.nan
    return float(np.sqrt(np.mean((a - b) ** 2)))


def max_error(ref, test, mask=None) -> float:
    """Largest absolute difference over the masked pixels and channels (NaN if none)."""
    a, b = _pair(ref, test, mask)
    return float(np.max(np.abs(a - b))) if a.size else math.nan


def psnr(ref, test, mask=None, data_range: float | None = None) -> float:
    """Peak signal-to-noise ratio in dB, by :func:`skimage.metrics.peak_signal_noise_ratio`.

    Parameters
    ----------
    ref, test : (H, W, C) or (H, W) float
        Linear images; ``ref`` is the ground truth.
    mask : (H, W) bool, optional
    data_range : float, optional
        The peak; default the reference's maximum over the masked pixels.

    Returns
    -------
    float
        ``inf`` for identical images (no division by zero is attempted),
        NaN for an empty mask or a zero peak.
    """
    a, b = _pair(ref, test, mask)
    if a.size == 0:
        return math.nan
    if np.array_equal(a, b):
        return math.inf
    peak = float(np.max(a)) if data_range is None else float(data_range)
    if not peak > 0:
        return math.nan
    skm = _require("skimage.metrics", "scikit-image", "PSNR")
    return float(skm.peak_signal_noise_ratio(a, b, data_range=peak))


def ssim(ref, test, mask=None, data_range: float | None = None) -> float:
    """Mean structural similarity over the masked pixels (scikit-image).

    Both images are set to zero outside ``mask`` first, so that a silhouette
    mismatch does not count twice, and the SSIM map is averaged over
    ``mask``.

    Parameters
    ----------
    ref, test : (H, W, 3) or (H, W) float
        At least 7 x 7 pixels.
    mask : (H, W) bool, optional
    data_range : float, optional
        Default the reference's maximum over the masked pixels.

    Returns
    -------
    float
        1 for identical images; NaN for an empty mask or a zero range.
    """
    skm = _require("skimage.metrics", "scikit-image", "SSIM")
    ref = np.asarray(ref, np.float64)
    test = np.asarray(test, np.float64)
    if ref.shape != test.shape:
        raise ValueError(f"images: shapes differ, {ref.shape} and {test.shape}")
    mask = np.ones(ref.shape[:2], bool) if mask is None else np.asarray(mask, bool)
    if not mask.any():
        return math.nan
    peak = float(np.max(ref[mask])) if data_range is None else float(data_range)
    if not peak > 0:
        return math.nan
    a = np.where(mask[..., None] if ref.ndim == 3 else mask, ref, 0.0)
    b = np.where(mask[..., None] if test.ndim == 3 else mask, test, 0.0)
    if min(a.shape[:2]) < 7:
        raise ValueError(f"ssim: images must be at least 7 x 7 pixels, got {a.shape[:2]}")
    _, smap = skm.structural_similarity(a, b, data_range=peak, channel_axis=2 if a.ndim == 3 else None, full=True)
    if smap.ndim == 3:
        smap = smap.mean(axis=2)
    return float(np.mean(smap[mask]))


def normal_angles(n_ref, n_test, mask=None) -> np.ndarray:
    """Angle between two normal buffers, in degrees.

    Computed as ``atan2(|a x b|, a.b)`` (accurate for small angles, where
    ``acos`` of the dot product is not); inputs need not be unit length.

    Parameters
    ----------
    n_ref, n_test : (H, W, 3) or (N, 3) float
    mask : (H, W) bool, optional

    Returns
    -------
    (M,) float64
        One angle per masked pixel (all pixels when ``mask`` is omitted),
        in [0, 180].
    """
    a = np.asarray(n_ref, np.float64)
    b = np.asarray(n_test, np.float64)
    if a.shape != b.shape or a.shape[-1] != 3:
        raise ValueError(f"normals: expected matching (..., 3) buffers, got {a.shape} and {b.shape}")
    if mask is not None:
        a = a[np.asarray(mask, bool)]
        b = b[np.asarray(mask, bool)]
    a = a.reshape(-1, 3)
    b = b.reshape(-1, 3)
    cross = np.linalg.norm(np.cross(a, b), axis=1)
    dot = np.einsum("ij,ij->i", a, b)
    return np.degrees(np.arctan2(cross, dot))


def highlight_position(image, mask=None, fraction: float = 0.002, min_pixels: int = 4):
    """Where the highlight is, to a fraction of a pixel.

    The intensity-weighted centroid of the ``k`` brightest pixels,
    ``k = max(min_pixels, ceil(fraction * n))`` of the ``n`` masked pixels,
    weighted by how much each exceeds the ``(k+1)``-th brightest (so the
    centroid moves continuously as pixels enter the set); ties at the top
    weigh equally.

    Parameters
    ----------
    image : (H, W, C) or (H, W) float
        Brightness is the mean over channels.
    mask : (H, W) bool, optional
    fraction : float
        Share of the masked pixels that form the highlight.
    min_pixels : int

    Returns
    -------
    (2,) float64
        ``(x, y)`` in pixel units, pixel centres at ``+0.5`` (the camera's
        convention); NaN when the mask is empty.
    """
    img = np.asarray(image, np.float64)
    lum = img.mean(axis=2) if img.ndim == 3 else img
    mask = np.ones(lum.shape, bool) if mask is None else np.asarray(mask, bool)
    ys, xs = np.nonzero(mask)
    if ys.size == 0:
        return np.array([math.nan, math.nan])
    vals = lum[ys, xs]
    k = int(min(vals.size, max(min_pixels, math.ceil(fraction * vals.size))))
    order = np.argsort(vals)[::-1]
    top = order[:k]
    floor = vals[order[k]] if k < vals.size else vals[top].min()
    w = vals[top] - floor
    if not w.sum() > 0:
        w = (vals[top] == vals[top].max()).astype(np.float64)
    w = w / w.sum()
    return np.array([np.sum(w * (xs[top] + 0.5)), np.sum(w * (ys[top] + 0.5))])


def flip(ref, test, mask=None, ppd: float | None = None) -> float:
    """Mean HDR-FLIP error (``flip-evaluator``) over the masked pixels.

    Parameters
    ----------
    ref, test : (H, W, 3) float
        Linear RGB, non-negative.
    mask : (H, W) bool, optional
    ppd : float, optional
        Pixels per degree of visual angle (FLIP's default 67).

    Returns
    -------
    float
        0 for identical images; NaN for an empty mask.
    """
    fl = _require("flip_evaluator", "flip-evaluator", "FLIP")
    ref = np.ascontiguousarray(np.clip(np.asarray(ref, np.float32), 0, None))
    test = np.ascontiguousarray(np.clip(np.asarray(test, np.float32), 0, None))
    if ref.shape != test.shape or ref.ndim != 3 or ref.shape[2] != 3:
        raise ValueError(f"flip: expected two (H, W, 3) images, got {ref.shape} and {test.shape}")
    mask = np.ones(ref.shape[:2], bool) if mask is None else np.asarray(mask, bool)
    if not mask.any():
        return math.nan
    params = {} if ppd is None else {"ppd": float(ppd)}
    emap, _, _ = fl.evaluate(ref, test, "HDR", inputsRGB=False, applyMagma=False, computeMeanError=False,
                             parameters=params)
    emap = np.asarray(emap, np.float64)
    if emap.ndim == 3:
        emap = emap[..., 0]
    return float(np.mean(emap[mask]))


def interior_mask(mask, rim: int = 2) -> np.ndarray:
    """(H, W) bool: ``mask`` without the pixels within ``rim`` pixels of its
    edge (8-connected erosion; the image border counts as edge)."""
    from scipy import ndimage

    mask = np.asarray(mask, bool)
    if rim <= 0:
        return mask.copy()
    return ndimage.binary_erosion(mask, structure=np.ones((3, 3), bool), iterations=int(rim), border_value=0)


def silhouette_mismatch(mask_ref, mask_test):
    """Pixels covered by one image only.

    Returns
    -------
    only_ref, only_test : int
    """
    mask_ref = np.asarray(mask_ref, bool)
    mask_test = np.asarray(mask_test, bool)
    return int(np.count_nonzero(mask_ref & ~mask_test)), int(np.count_nonzero(mask_test & ~mask_ref))


@dataclass(frozen=True)
class Comparison:
    """All metrics of one test image against its reference (see the module docstring).

    Attributes
    ----------
    n_common, only_ref, only_test : int
    rmse, psnr, max_error, rmse_interior, ssim, mean_angle, p95_angle, highlight, flip : float
        NaN where not computed (no normals, a missing optional package that
        was not asked for, or no common pixels).
    """

    n_common: int
    only_ref: int
    only_test: int
    rmse: float
    psnr: float
    max_error: float
    rmse_interior: float = math.nan
    ssim: float = math.nan
    mean_angle: float = math.nan
    p95_angle: float = math.nan
    highlight: float = math.nan
    flip: float = math.nan

    def as_dict(self) -> dict:
        return asdict(self)


def compare(reference, test, *, normals: bool = True, use_ssim: bool = True, use_flip: bool = False,
            highlight_fraction: float = 0.002, rim: int = 2) -> Comparison:
    """Compare a rendered frame with its ground truth.

    Parameters
    ----------
    reference, test : Frame, ExactFrame or (H, W, 3) array
        Anything with ``image`` (and ``mask``, ``normal``) attributes, or a
        bare image (then every pixel counts as covered and normals are skipped).
    normals : bool
        Compare ``normal`` buffers when both have them.
    use_ssim : bool
        SSIM (needs scikit-image).
    use_flip : bool
        FLIP (needs flip-evaluator).
    highlight_fraction : float
        See :func:`highlight_position`.
    rim : int
        Width in pixels of the silhouette band left out of ``rmse_interior``.

    Returns
    -------
    Comparison
    """
    ri = _image(reference, "reference")
    ti = _image(test, "test")
    if ri.shape != ti.shape:
        raise ValueError(f"reference and test: image shapes differ, {ri.shape} and {ti.shape}")
    rm = _mask(reference, ri, "reference")
    tm = _mask(test, ti, "test")
    both = common_mask(rm, tm)
    only_ref, only_test = silhouette_mismatch(rm, tm)
    out = dict(n_common=int(both.sum()), only_ref=only_ref, only_test=only_test,
               rmse=rmse(ri, ti, both), psnr=psnr(ri, ti, both), max_error=max_error(ri, ti, both))
    if not both.any():
        return Comparison(**out)
    out["rmse_interior"] = rmse(ri, ti, interior_mask(both, rim))
    if use_ssim and min(ri.shape[:2]) >= 7:
        out["ssim"] = ssim(ri, ti, both)
    if normals and getattr(reference, "normal", None) is not None and getattr(test, "normal", None) is not None:
        ang = normal_angles(reference.normal, test.normal, both)
        out["mean_angle"] = float(ang.mean())
        out["p95_angle"] = float(np.percentile(ang, 95))
    hr = highlight_position(ri, both, highlight_fraction)
    ht = highlight_position(ti, both, highlight_fraction)
    out["highlight"] = float(np.hypot(*(hr - ht)))
    if use_flip and ri.shape[2] == 3:
        out["flip"] = flip(ri, ti, both)
    return Comparison(**out)


def angular_step(mesh) -> float:
    """The mesh's angular step: mean angle between the normals at the two ends of an edge.

    With exact vertex normals this is the angle the surface turns across one
    triangle: ``h * curvature`` for edge length ``h``, the variable in which
    shading errors converge.

    Parameters
    ----------
    mesh : Mesh
        Its resolved (``prepared``) vertex normals are used.

    Returns
    -------
    float
        Radians, over the unique edges with two non-zero normals (NaN if none).
    """
    prep = mesh.prepared
    f = np.asarray(prep.faces, np.int64)
    edges = np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]])
    edges = np.unique(np.sort(edges, axis=1), axis=0)
    a = prep.normals[edges[:, 0]]
    b = prep.normals[edges[:, 1]]
    ok = np.any(a != 0, axis=1) & np.any(b != 0, axis=1)
    if not ok.any():
        return math.nan
    return float(np.radians(normal_angles(a[ok], b[ok])).mean())


def convergence_order(steps, errors):
    """Least-squares slope of ``log(error)`` against ``log(step)``.

    Parameters
    ----------
    steps : (N,) float
        Mesh steps (e.g. :func:`angular_step`), ``> 0``.
    errors : (N,) float
        Errors at those steps; non-positive or non-finite pairs are dropped.

    Returns
    -------
    order : float
        ``p`` in ``error ~ C step^p``; NaN with fewer than two usable points.
    stderr : float
        Its standard error (NaN with fewer than three points).
    """
    x = np.asarray(steps, np.float64)
    y = np.asarray(errors, np.float64)
    if x.shape != y.shape:
        raise ValueError(f"steps and errors: shapes differ, {x.shape} and {y.shape}")
    ok = np.isfinite(x) & np.isfinite(y) & (x > 0) & (y > 0)
    x = np.log(x[ok])
    y = np.log(y[ok])
    if x.size < 2 or np.ptp(x) == 0:
        return math.nan, math.nan
    xm = x - x.mean()
    slope = float(np.sum(xm * (y - y.mean())) / np.sum(xm * xm))
    if x.size < 3:
        return slope, math.nan
    resid = y - (y.mean() + slope * xm)
    stderr = float(np.sqrt(np.sum(resid ** 2) / (x.size - 2) / np.sum(xm * xm)))
    return slope, stderr
