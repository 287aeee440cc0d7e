"""Optical flow on disk: Middlebury ``.flo``, KITTI's 16-bit PNG, and the flow colour wheel.

* ``.flo`` (Middlebury, Baker et al. 2011; what ``cv2.readOpticalFlow`` reads): the float32
  ``202021.25`` (the bytes ``PIEH``), int32 width, int32 height, then float32 ``u, v``
  interleaved, row-major, all little-endian. Pixels without a flow hold ``1e10`` (Middlebury's
  "unknown": any ``|u|`` or ``|v|`` above ``1e9``).
* KITTI's flow PNG (Geiger et al. 2012's devkit): 16-bit RGB, ``R = u * 64 + 2**15``,
  ``G = v * 64 + 2**15`` (rounded to the nearest 1/64 pixel), ``B = 1`` where the flow is valid
  and ``0`` elsewhere; ``u`` along x (columns, right) and ``v`` along y (rows, down) in pixels, so
  ``|u|, |v| <= 512 - 1/64``. A flow beyond that cannot be written: it is clamped, its pixel
  marked invalid, and a :class:`FlowRangeWarning` says how many.

:func:`flow_colors` draws a flow as a picture with the Middlebury colour wheel (hue: direction,
saturation: length).
"""

from __future__ import annotations

import os
import warnings

import numpy as np

from ..common.validate import as_array, as_path, as_scalar

__all__ = ["FLO_MAGIC", "UNKNOWN_FLOW", "KITTI_SCALE", "KITTI_MAX", "FlowRangeWarning", "write_flo", "read_flo",
           "write_flow_png", "read_flow_png", "flow_colors", "color_wheel"]

FLO_MAGIC = 202021.25
UNKNOWN_FLOW = 1e10  # Middlebury's value for "no flow here" (its readers treat |u| > 1e9 as unknown)
KITTI_SCALE = 64.0
KITTI_MAX = (65535 - 2**15) / KITTI_SCALE  # the largest |u| or |v| a KITTI PNG holds: 512 - 1/64 px


class FlowRangeWarning(UserWarning):
    """A flow a KITTI PNG cannot hold (beyond +-512 pixels): clamped and marked invalid."""


def _flow(flow, name="flow") -> np.ndarray:
    f = as_array(flow, name, dtype=np.float64, finite=False)
    if f.ndim != 3 or f.shape[2] != 2 or f.shape[0] < 1 or f.shape[1] < 1:
        raise ValueError(f"{name}: expected an (H, W, 2) array of u, v, got shape {f.shape}")
    if np.isnan(f).any():
        raise ValueError(f"{name}: holds NaN (mark pixels without a flow with valid=False)")
    return f


def _valid(valid, shape, name="valid") -> np.ndarray:
    if valid is None:
        return np.ones(shape, bool)
    m = np.asarray(valid)
    if m.dtype != bool or m.shape != shape:
        raise ValueError(f"{name}: expected an {shape} bool array, got {m.dtype} {m.shape}")
    return m


def write_flo(path, flow, valid=None) -> str:
    """Write a Middlebury ``.flo`` file (see the module docstring), atomically.

    Parameters
    ----------
    path : str or path-like
        Ends in ``.flo``.
    flow : (H, W, 2) float
        ``u, v`` in pixels; stored as float32.
    valid : (H, W) bool, optional
        Where the flow is known; elsewhere :data:`UNKNOWN_FLOW` is written. Default: everywhere.

    Returns
    -------
    str
        The path.
    """
    from .imagefile import atomic_target

    path = as_path(path, "path")
    if not path.lower().endswith(".flo"):
        raise ValueError(f"path: {path!r}: expected a .flo file")
    f = _flow(flow)
    known = _valid(valid, f.shape[:2])
    if not np.isfinite(f[known]).all():
        raise ValueError("flow: holds inf where valid (only pixels without a flow may)")
    data = np.where(known[..., None], f, UNKNOWN_FLOW).astype("<f4")
    with atomic_target(path) as tmp, open(tmp, "wb") as fh:
        fh.write(np.array([FLO_MAGIC], "<f4").tobytes())
        fh.write(np.array([f.shape[1], f.shape[0]], "<i4").tobytes())
        fh.write(data.tobytes())
    return path


def read_flo(path) -> np.ndarray:
    """(H, W, 2) float32 flow of a ``.flo`` file, bit for bit what it holds (unknown: ``> 1e9``).

    Raises
    ------
    ValueError
        Naming the file: another magic number, a size that does not match its length.
    """
    path = as_path(path, "path")
    with open(path, "rb") as fh:
        raw = fh.read()
    if len(raw) < 12:
        raise ValueError(f"{path}: {len(raw)} bytes, shorter than a .flo header (12)")
    magic = float(np.frombuffer(raw[:4], "<f4")[0])
    if magic != FLO_MAGIC:
        raise ValueError(f"{path}: not a .flo file (magic {magic!r}, expected {FLO_MAGIC})")
    w, h = (int(x) for x in np.frombuffer(raw[4:12], "<i4"))
    if w < 1 or h < 1 or len(raw) != 12 + 8 * w * h:
        raise ValueError(f"{path}: header says {w}x{h}, which does not match its {len(raw)} bytes")
    return np.frombuffer(raw[12:], "<f4").reshape(h, w, 2).astype(np.float32)


def write_flow_png(path, flow, valid=None) -> str:
    """Write a flow as KITTI's 16-bit PNG (see the module docstring), atomically.

    Parameters
    ----------
    path : str or path-like
        Ends in ``.png``.
    flow : (H, W, 2) float
        ``u, v`` in pixels (any value where ``valid`` is False; written as 0 there).
    valid : (H, W) bool, optional
        The ``B`` channel; default: everywhere.

    Returns
    -------
    str
        The path.

    Warns
    -----
    FlowRangeWarning
        For valid pixels whose flow exceeds :data:`KITTI_MAX`: clamped and written invalid.
    """
    from .imagefile import atomic_target, png_bytes

    path = as_path(path, "path")
    if not path.lower().endswith(".png"):
        raise ValueError(f"path: {path!r}: expected a .png file")
    f = _flow(flow)
    ok = _valid(valid, f.shape[:2]).copy()
    f = np.where(ok[..., None], f, 0.0)
    far = ok & (np.abs(f) > KITTI_MAX).any(axis=2)
    if far.any():
        warnings.warn(f"{path}: {int(far.sum())} pixels' flow exceeds the +-{KITTI_MAX} px a KITTI PNG holds: "
                      "clamped and marked invalid (B = 0); the .flo file keeps it", FlowRangeWarning, stacklevel=2)
        ok &= ~far
    code = np.clip(np.rint(np.clip(f, -KITTI_MAX, KITTI_MAX) * KITTI_SCALE) + 2**15, 0, 65535).astype(np.uint16)
    image = np.dstack([code, ok.astype(np.uint16)])
    with atomic_target(path) as tmp, open(tmp, "wb") as fh:
        fh.write(png_bytes(image))
    return path


def read_flow_png(path) -> tuple:
    """``(flow, valid)`` of a KITTI flow PNG: (H, W, 2) float64 pixels and (H, W) bool.

    Raises
    ------
    ValueError
        Naming the file when it is not a 16-bit RGB PNG.
    ImportError
        Without OpenCV (the ``vision`` extra).
    """
    path = as_path(path, "path")
    if not os.path.isfile(path):
        raise FileNotFoundError(f"path: no file {path!r}")
    try:  # Pillow (imageio's PNG reader) reads 16-bit RGB as 8 bits: OpenCV keeps them
        import cv2
    except ImportError:
        raise ImportError("reading a 16-bit RGB PNG takes OpenCV: pip install opencv-python-headless "
                          "(raycast_shade[vision])") from None
    image = cv2.imread(path, cv2.IMREAD_UNCHANGED)
    if image is None or image.dtype != np.uint16 or image.ndim != 3 or image.shape[2] != 3:
        what = "unreadable" if image is None else f"{image.dtype} {image.shape}"
        raise ValueError(f"{path}: expected a 16-bit RGB PNG (KITTI flow), got {what}")
    image = image[..., ::-1]  # OpenCV's BGR to the file's RGB
    flow = (image[..., :2].astype(np.float64) - 2**15) / KITTI_SCALE
    return flow, image[..., 2] > 0


def color_wheel() -> np.ndarray:
    """(55, 3) float64 colours in [0, 255] around the Middlebury flow wheel: red, yellow, green,
    cyan, blue, magenta, in 15, 6, 4, 11, 13, 6 steps (Baker et al. 2011's segments)."""
    segments = [(15, (255, 0, 0), (255, 255, 0)), (6, (255, 255, 0), (0, 255, 0)),
                (4, (0, 255, 0), (0, 255, 255)), (11, (0, 255, 255), (0, 0, 255)),
                (13, (0, 0, 255), (255, 0, 255)), (6, (255, 0, 255), (255, 0, 0))]
    rows = []
    for n, a, b in segments:
        s = np.floor(255.0 * np.arange(n) / n) / 255.0  # the devkit's integer steps
        rows.append(np.outer(1.0 - s, a) + np.outer(s, b))
    return np.concatenate(rows)


def flow_colors(flow, valid=None, *, max_flow=None, background=(0, 0, 0)) -> np.ndarray:
    """(H, W, 3) uint8 picture of a flow on the Middlebury colour wheel.

    Parameters
    ----------
    flow : (H, W, 2) float
    valid : (H, W) bool, optional
        Pixels drawn; the others take ``background``.
    max_flow : float, optional
        The length drawn fully saturated (default: the longest valid flow; longer flows are
        darkened by a quarter, as the devkit draws them).
    background : (3,) int
        Colour of the pixels without a flow.

    Returns
    -------
    (H, W, 3) uint8
        Hue: the direction (right red, down yellow, left cyan, up blue-violet), saturation: the
        length (white: no motion).
    """
    f = _flow(flow)
    ok = _valid(valid, f.shape[:2]) & np.isfinite(f).all(axis=2)
    background = as_array(background, "background", dtype=np.uint8, shape=(3,))
    u, v = np.where(ok, f[..., 0], 0.0), np.where(ok, f[..., 1], 0.0)
    rad = np.hypot(u, v)
    if max_flow is None:
        max_flow = float(rad[ok].max(initial=0.0))
    else:
        max_flow = as_scalar(max_flow, "max_flow", minimum=0.0, exclusive=True)
    r = rad / max(max_flow, 1e-12)
    wheel = color_wheel() / 255.0
    n = len(wheel)
    a = np.arctan2(-v, -u) / np.pi
    fk = (a + 1.0) / 2.0 * (n - 1)
    k0 = np.floor(fk).astype(int)
    k1 = (k0 + 1) % n
    frac = (fk - k0)[..., None]
    col = (1.0 - frac) * wheel[k0] + frac * wheel[k1]
    inside = (r <= 1.0)[..., None]
    col = np.where(inside, 1.0 - r[..., None] * (1.0 - col), col * 0.75)
    out = np.floor(255.0 * col).astype(np.uint8)
    out[~ok] = background
    return out
