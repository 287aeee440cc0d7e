"""Writing and reading a frame's buffers: NumPy ``.npz``, multi-channel EXR, 16-bit depth PNG.

* ``.npz``: every buffer under its name (and the linear ``image`` and the
  camera's ``K``, ``R``, ``t`` when given), dtypes kept.
* ``.exr`` (the ``openexr`` package, extra ``vision``): float32 channels,
  ZIP-compressed. The image is ``R, G, B``; a scalar buffer is the channel
  ``name``; a 3-vector buffer ``name.X, name.Y, name.Z``; ids are ``UINT``
  channels holding ``id + 1`` (0 on the background), the mask a ``UINT``
  0/1 channel. :func:`read_exr` undoes all of it.
* depth PNG: one 16-bit grey channel in millimetres (``scale`` units per
  metre-like world unit, default 1000), 0 where nothing was hit or the depth
  is out of range, as TUM RGB-D, ScanNet and NYU store it.

Every writer takes ``atomic=True`` (through
:func:`~raycast_shade.output.imagefile.atomic_target`): the file is whole or
absent, never partial.
"""

from __future__ import annotations

import contextlib
import os

import numpy as np

from .imagefile import atomic_target

__all__ = ["save_npz", "load_npz", "write_exr", "read_exr", "write_depth_png", "read_depth_png"]

_ID_BUFFERS = ("model_id", "triangle_id")
_AXES = ("X", "Y", "Z")


@contextlib.contextmanager
def _target(path, atomic):
    path = os.fspath(path)
    if atomic:
        with atomic_target(path) as tmp:
            yield tmp
    else:
        yield path


def save_npz(path, buffers: dict, *, image=None, camera=None, compressed: bool = True, atomic: bool = False) -> str:
    """Write buffers (and optionally the image and the camera's K, R, t) to one ``.npz``.

    Parameters
    ----------
    path : str or path-like
        Ends in ``.npz``.
    buffers : dict of str to ndarray
    image : (H, W, 3) float32, optional
    camera : Camera, optional
    compressed : bool
        ``np.savez_compressed`` (zlib) or ``np.savez``.

    Returns
    -------
    str
        ``path``.
    """
    path = os.fspath(path)
    if not path.lower().endswith(".npz"):
        raise ValueError(f"path: {path!r}: expected a .npz file")
    arrays = dict(buffers)
    if image is not None:
        arrays["image"] = np.asarray(image, np.float32)
    if camera is not None:
        arrays["K"], arrays["R"], arrays["t"] = camera.to_opencv()
    with _target(path, atomic) as target, open(target, "wb") as fh:
        (np.savez_compressed if compressed else np.savez)(fh, **arrays)
    return path


def load_npz(path) -> dict:
    """Every array of a :func:`save_npz` file, by name."""
    with np.load(os.fspath(path)) as data:
        return {k: data[k] for k in data.files}


def _exr_channels(buffers, image):
    channels = {}
    if image is not None:
        img = np.asarray(image, np.float32)
        for i, c in enumerate("RGB"):
            channels[c] = np.ascontiguousarray(img[..., i])
    for name, buf in buffers.items():
        if name in _ID_BUFFERS:
            channels[name] = np.ascontiguousarray(buf.astype(np.int64) + 1, dtype=np.uint32)
        elif buf.dtype == np.bool_:
            channels[name] = buf.astype(np.uint32)
        elif buf.ndim == 3:
            for i, axis in enumerate(_AXES):
                channels[f"{name}.{axis}"] = np.ascontiguousarray(buf[..., i], dtype=np.float32)
        else:
            channels[name] = np.ascontiguousarray(buf, dtype=np.float32)
    return channels


def write_exr(path, buffers: dict, *, image=None, atomic: bool = False) -> str:
    """Write buffers (and optionally the linear image) as one multi-channel EXR.

    Raises
    ------
    ImportError
        Without the ``openexr`` package (``pip install raycast_shade[vision]``).
    """
    try:
        import OpenEXR
    except ImportError as exc:
        raise ImportError("write_exr: needs the openexr package (pip install 'raycast_shade[vision]')") from exc
    path = os.fspath(path)
    if not path.lower().endswith(".exr"):
        raise ValueError(f"path: {path!r}: expected a .exr file")
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    with _target(path, atomic) as target, OpenEXR.File(header, _exr_channels(buffers, image)) as f:
        f.write(target)
    return path


def read_exr(path) -> dict:
    """The buffers (and ``image``) of a :func:`write_exr` file, with their written dtypes and shapes."""
    import OpenEXR

    with OpenEXR.File(os.fspath(path), separate_channels=True) as f:
        ch = {k: v.pixels for k, v in f.channels().items()}
    out = {}
    if all(c in ch for c in "RGB"):
        out["image"] = np.stack([ch.pop(c) for c in "RGB"], axis=-1)
    vectors = sorted({k.rsplit(".", 1)[0] for k in ch if k.endswith((".X", ".Y", ".Z"))})
    for name in vectors:
        out[name] = np.stack([ch.pop(f"{name}.{a}") for a in _AXES], axis=-1)
    for name, px in ch.items():
        if name in _ID_BUFFERS:
            out[name] = (px.astype(np.int64) - 1).astype(np.int32)
        elif name == "mask":
            out[name] = px.astype(bool)
        else:
            out[name] = px
    return out


def write_depth_png(path, depth, *, scale: float = 1000.0, atomic: bool = False) -> str:
    """Write depth as a 16-bit grey PNG of ``round(depth * scale)``.

    Parameters
    ----------
    depth : (H, W) float
        Depth in world units; 0 (or not finite) where there is none.
    scale : float
        Stored units per world unit (1000: millimetres from metres).

    Notes
    -----
    Values that round to more than 65535 are stored as 0 (no depth), not
    clamped, so a reader never mistakes them for a surface.
    """
    import struct
    import zlib

    d = np.asarray(depth, np.float64)
    if d.ndim != 2:
        raise ValueError(f"depth: expected an (H, W) array, got shape {d.shape}")
    if not (isinstance(scale, (int, float)) and np.isfinite(scale) and scale > 0):
        raise ValueError(f"scale: expected a finite number > 0, got {scale!r}")
    q = np.where(np.isfinite(d) & (d > 0), np.rint(d * scale), 0.0)
    q = np.where(q <= 65535, q, 0.0).astype(">u2")  # PNG stores 16-bit samples big-endian
    h, w = q.shape
    raw = np.zeros((h, 2 * w + 1), np.uint8)  # filter type 0 on every row
    raw[:, 1:] = q.view(np.uint8).reshape(h, 2 * w)

    def chunk(tag: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + tag + data + struct.pack(">I", zlib.crc32(tag + data))

    header = struct.pack(">IIBBBBB", w, h, 16, 0, 0, 0, 0)  # 16-bit greyscale, no interlace
    with _target(path, atomic) as target, open(target, "wb") as fh:
        fh.write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) + chunk(b"IDAT", zlib.compress(raw.tobytes(), 6))
                 + chunk(b"IEND", b""))
    return os.fspath(path)


def read_depth_png(path, *, scale: float = 1000.0) -> np.ndarray:
    """(H, W) float32 depth of a :func:`write_depth_png` file (0: none)."""
    import imageio.v3 as iio

    return (iio.imread(os.fspath(path)).astype(np.float64) / scale).astype(np.float32)
