"""Reading a student's image and scoring candidate explanations against it.

Everything is compared in display values on the 0..255 scale (what an 8-bit
file holds), so a candidate's encoding (sRGB once, none, twice) is one of the
things it explains, and 8-bit quantisation and clipping at 1 apply to the
candidates exactly as to the student's renderer.

The score of a candidate is the root of the mean truncated squared
difference over the *interior* pixels (:func:`interior_weights`): a pixel
whose 3 x 3 neighbourhood sees one surface (or only background) in our
frame, in its flipped copy and in the half-pixel-shifted cast, so the
student's own anti-aliasing and silhouette rounding never count. Truncating
each channel's difference at :data:`CAP` levels keeps a few wild pixels (a
stray overlay, a different background) from outweighing the rest.
"""

from __future__ import annotations

import os

import numpy as np

__all__ = ["read_student", "interior_weights", "sse", "sse_filtered", "fitted_image", "CAP", "MAX_SHIFT", "MAX_BLUR"]

CAP = 64.0  # levels: a channel's difference counts at most CAP^2


def read_student(image, shape) -> np.ndarray:
    """The student's image as (H, W, 3) float64 display values in levels 0..255.

    Parameters
    ----------
    image : str, os.PathLike or array
        An image file (PNG, JPEG, ... through imageio), or an array: uint8
        (levels), uint16 (levels x 257) or float (display values in [0, 1],
        alpha included; values outside are refused, not clipped).
        (H, W, 3) or (H, W, 4) (alpha must be opaque and is dropped).
    shape : (H, W)
        The size the scene's camera renders.

    Raises
    ------
    ValueError
        Unreadable or non-image file, wrong size, wrong channels, a blank
        (single-valued) image, a translucent alpha channel, non-finite values
        (alpha too), float values outside [0, 1].
    """
    name = "image"
    if isinstance(image, (str, os.PathLike)):
        name = f"image {os.fspath(image)!r}"
        if not os.path.isfile(image):
            raise ValueError(f"{name}: no such file")
        import imageio.v3 as iio

        try:
            arr = np.asarray(iio.imread(image, plugin="pillow"))  # PNG, JPEG, BMP, TIFF, ... (8 or 16 bit)
        except Exception as exc:  # imageio raises many kinds for non-images
            raise ValueError(f"{name}: not an image file we can read ({type(exc).__name__}: {exc})") from None
    else:
        arr = np.asarray(image)
    if arr.dtype == np.uint8:
        x = arr.astype(np.float64)
    elif arr.dtype == np.uint16:
        x = arr.astype(np.float64) / 257.0
    elif arr.dtype.kind == "f":
        x = arr.astype(np.float64) * 255.0
    else:
        raise TypeError(f"{name}: expected uint8, uint16 or float pixels, got {arr.dtype}")
    if x.ndim != 3 or x.shape[2] not in (3, 4):
        raise ValueError(f"{name}: expected an RGB or RGBA image (H, W, 3 or 4), got shape {arr.shape}")
    h, w = shape
    if x.shape[:2] != (h, w):
        raise ValueError(f"{name}: is {x.shape[1]}x{x.shape[0]} pixels but the scene's camera renders {w}x{h}")
    # Alpha included, and before its test: NaN < 254.5 is False, so a NaN alpha passed as opaque.
    if not np.all(np.isfinite(x)):
        where = "alpha channel" if x.shape[2] == 4 and not np.all(np.isfinite(x[..., 3])) else "pixels"
        raise ValueError(f"{name}: has non-finite {where} (NaN or inf)")
    if arr.dtype.kind == "f":
        _check_float_range(arr, name)
    if x.shape[2] == 4:
        if np.any(x[..., 3] < 254.5):
            raise ValueError(f"{name}: has transparent pixels; composite it on the scene's background first")
        x = x[..., :3]
    if np.ptp(x) == 0:
        raise ValueError(f"{name}: is blank (every pixel is {x.flat[0] / 255.0:.4g}); nothing to diagnose")
    return x


def _check_float_range(arr, name: str) -> None:
    """Refuse a float image outside [0, 1]: read as display values, 0-255 levels or an unclipped
    linear image would be scored as if valid (every pixel clipped to white or black)."""
    hi, lo = float(np.max(arr)), float(np.min(arr))
    if hi > 1.0:
        hint = ("pass the uint8 array or divide by 255" if hi > 2.0 else
                "clip it to [0, 1] as writing an 8-bit file would")  # just above 1: an unclipped image
        raise ValueError(f"{name}: float values up to {hi:.6g}: a float image is in [0, 1]; {hint}")
    if lo < 0.0:
        raise ValueError(f"{name}: float values down to {lo:.6g}: a float image is in [0, 1]; "
                         "clip it to [0, 1] as writing an 8-bit file would")


def _edges(label) -> np.ndarray:
    """(H, W) bool: pixels whose 3 x 3 neighbourhood holds more than one label."""
    pad = np.pad(label, 1, mode="edge")
    h, w = label.shape
    out = np.zeros(label.shape, bool)
    for dy in (0, 1, 2):
        for dx in (0, 1, 2):
            out |= pad[dy:dy + h, dx:dx + w] != label
    return out


def interior_weights(labels) -> np.ndarray:
    """(H, W) float64 weights: 1 where no label map has an edge, else 0.

    Parameters
    ----------
    labels : sequence of (H, W) int
        Per-pixel surface labels (model index, -1 for background) of the
        frames the candidates are made from, in the student's pixel grid.
    """
    edge = np.zeros(np.shape(labels[0]), bool)
    for lab in labels:
        edge |= _edges(np.asarray(lab))
    return (~edge).astype(np.float64)


def sse(a, b, weights) -> float:
    """Weighted sum of per-channel squared differences, each truncated at CAP^2.

    Parameters
    ----------
    a, b : (H, W, 3) float64
        Levels 0..255.
    weights : (H, W) float64
    """
    d = np.minimum(np.square(a - b), CAP * CAP)
    return float(np.einsum("hwc,hw->", d, np.asarray(weights, np.float64)))


MAX_SHIFT = 0.25  # pixels: the sub-pixel shift a student's sample pattern may add (half-pixel is a candidate)
MAX_BLUR = 0.125  # weight of the 4-neighbour Laplacian: up to a box filter a pixel wide and more


def _derivatives(img):
    """Central x and y differences and the 4-neighbour Laplacian of (H, W, 3), edges replicated."""
    p = np.pad(img, ((1, 1), (1, 1), (0, 0)), mode="edge")
    gx = 0.5 * (p[1:-1, 2:] - p[1:-1, :-2])
    gy = 0.5 * (p[2:, 1:-1] - p[:-2, 1:-1])
    lap = p[:-2, 1:-1] + p[2:, 1:-1] + p[1:-1, :-2] + p[1:-1, 2:] - 4.0 * img
    return gx, gy, lap


def sse_filtered(student, cand, weights):
    """:func:`sse` after the best small shift and blur of the candidate.

    A student's own anti-aliasing averages samples around each pixel centre:
    to first and second order the candidate plus ``a dC/dx + b dC/dy``
    (the pattern's mean offset) plus ``w`` times its Laplacian (the spread).
    ``a, b`` and ``w`` are fitted by least squares on the interior pixels and
    clipped to ``|a|, |b| <= MAX_SHIFT``, ``0 <= w <= MAX_BLUR``, so that a
    sub-pixel pattern is not held against the image while a half-pixel
    offset stays a mistake of its own.

    Returns
    -------
    sse : float
    params : (3,) float64
        ``a, b, w``.
    """
    gx, gy, lap = _derivatives(cand)
    sel = weights > 0
    basis = np.stack([gx[sel].ravel(), gy[sel].ravel(), lap[sel].ravel()], axis=1)
    resid = (student - cand)[sel].ravel()
    gram = basis.T @ basis
    if not np.all(np.isfinite(gram)) or np.linalg.cond(gram) > 1e12:
        return sse(student, cand, weights), np.zeros(3)
    params = np.linalg.solve(gram, basis.T @ resid)
    params = np.clip(params, [-MAX_SHIFT, -MAX_SHIFT, 0.0], [MAX_SHIFT, MAX_SHIFT, MAX_BLUR])
    return sse(student, fitted_image(cand, params), weights), params


def fitted_image(cand, params) -> np.ndarray:
    """(H, W, 3) float64: ``cand`` shifted by ``params[:2]`` and blurred by ``params[2]`` (to first and second
    order, as :func:`sse_filtered` fits them)."""
    gx, gy, lap = _derivatives(np.asarray(cand, np.float64))
    return cand + params[0] * gx + params[1] * gy + params[2] * lap
