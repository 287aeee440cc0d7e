"""Bytes of one frame, by what is asked for: the table behind
:meth:`~raycast_shade.scene.camera.Camera.check_frame_memory`, which
``render()`` calls with the buffers, samples and terms asked for, before any
kernel runs. Checked against measured peaks in
``tests/scene/test_frame_memory.py``.

``render()``'s whole-frame path (:func:`frame_bytes_per_pixel`):

* the frame itself, :data:`FRAME_BYTES_PER_PIXEL` = 47: the hit buffer 20,
  the linear image 12, the shading normals 12 (on first access; none when
  the ``normal`` buffer is asked for: ``frame.normal`` is that buffer) and
  the 8-bit image 3;
* each buffer its stored bytes, :data:`BUFFER_BYTES` (the writers store
  the same), plus 12 for the shading normals a ``normal_camera`` buffer is
  computed from (a ``normal`` buffer holds them itself); a buffer written
  into the caller's array (``render(buffers_out=...)``) counts nothing;
* ``samples=N > 1``: one more hit buffer (one per sample of a group of 4
  when ``coverage`` is counted), up to 3 more images, a float64
  accumulator beyond 4 samples (and an int32 hit count with ``coverage``);
* ``terms``: the ambient, diffuse, specular and reflected images and one
  being shaded (5 x 12), the shadow mask (4 per light), and with
  ``"per_light"`` each light's diffuse and specular images (24 per light).

The banded path (:func:`frame_bytes` with ``band_rows``) holds no
full-frame hit buffer while it renders (the frame casts it again when
``frame.hits`` is read, as ``frame.normal`` does, so the plain frame's 47 stay
counted; with the ``normal`` buffer nothing reads the hits, and the frame
counts 15: its images), only its hit mask (1) and per band: each sample's cast window (20 bytes a pixel of
``band_rows + 2`` rows), the shading normals of a ``normal_camera`` buffer
(12) and, with several samples, up to 4 band images and a float64
accumulator (and int32 count). That scratch is freed before the hits,
normals and 8-bit image (35 bytes a pixel) are made on access, so only what
it exceeds them by counts.
"""

from __future__ import annotations

from ..common.bufferspec import ALIASES, REGISTRY

__all__ = ["FRAME_BYTES_PER_PIXEL", "BUFFER_BYTES", "frame_bytes_per_pixel", "frame_bytes"]

FRAME_BYTES_PER_PIXEL = 20 + 12 + 12 + 3
#: Bytes per pixel of each buffer as stored: render()'s arrays and the buffer files alike.
BUFFER_BYTES = {spec.name: spec.bytes for spec in REGISTRY}
_HITS, _IMAGE, _NORMALS, _GROUP = 20, 12, 12, 4


def frame_bytes_per_pixel(buffers=(), samples: int = 1, terms=None, lights: int = 0, reused=()) -> int:
    """Bytes per pixel a frame needs with these options.

    Parameters
    ----------
    buffers : sequence of str
        Buffer names (:data:`BUFFER_BYTES` or ``"id"``); duplicates count once.
    samples : int
        Rays per pixel, ``>= 1``.
    terms : None, or sequence of str
        ``render``'s checked terms: None for none, ``()`` for the summed
        terms, ``("per_light",)`` for each light's too.
    lights : int
        The scene's lights (for the terms).
    reused : sequence of str
        Buffers written into the caller's arrays (``render(buffers_out=...)``): asked for, but
        no new memory.

    Raises
    ------
    ValueError
        For an unknown buffer name (naming ``buffers``) or ``samples < 1``.
    """
    names = _names(buffers)
    n = _samples(samples)
    total = FRAME_BYTES_PER_PIXEL + sum(BUFFER_BYTES[b] for b in names - _names(reused))
    if "normal" in names:  # frame.normal is the buffer
        total -= _NORMALS
    if "normal_camera" in names and "normal" not in names:
        total += _NORMALS
    if n > 1:
        counted = "coverage" in names
        total += _HITS * (min(n - 1, _GROUP) if counted else 1) + _IMAGE * (min(n, _GROUP) - 1)
        total += (8 * 3 + (4 if counted else 0)) if n > _GROUP else 0
    return total + _terms_bytes(terms, lights)


def _terms_bytes(terms, lights: int) -> int:
    """Bytes per pixel of the terms (none for ``terms=None``), on either path."""
    if terms is None:
        return 0
    return 5 * _IMAGE + 4 * lights + (2 * _IMAGE * lights if "per_light" in terms else 0)


def frame_bytes(width: int, height: int, buffers=(), samples: int = 1, terms=None, lights: int = 0,
                band_rows: int = 0, reused=()) -> float:
    """Bytes a frame of ``width`` x ``height`` pixels needs with these options.

    Parameters
    ----------
    width, height : int
    buffers, samples, terms, lights, reused
        As :func:`frame_bytes_per_pixel`.
    band_rows : int
        Rows per band of a frame ``render()`` renders band by band (its terms,
        if asked for, are full-frame arrays written band by band); 0 for the
        whole-frame path.

    Returns
    -------
    float
    """
    px = float(width) * float(height)
    if not band_rows:
        return px * frame_bytes_per_pixel(buffers, samples, terms, lights, reused)
    names = _names(buffers)
    n = _samples(samples)
    # Made on access after the bands: the hits and the shading normals (unless the normal buffer is
    # frame.normal; then nothing reads the hits) and the 8-bit image.
    after = 3 if "normal" in names else _HITS + _NORMALS + 3
    per_pixel = (FRAME_BYTES_PER_PIXEL - (_HITS + _NORMALS + 3) + after + 1
                 + sum(BUFFER_BYTES[b] for b in names - _names(reused)) + _terms_bytes(terms, lights))
    rows = min(int(band_rows) + 2, int(height))  # a window: the band, the row above and the waiting row
    band = _HITS * n  # every sample's window
    if "normal_camera" in names and "normal" not in names:
        band += _NORMALS
    if n > 1:
        band += _IMAGE * min(n, _GROUP) + ((8 * 3 + (4 if "coverage" in names else 0)) if n > _GROUP else 0)
    # The band scratch is gone before the frame's hits, normals and 8-bit image are made on access.
    return px * per_pixel + max(0.0, float(rows) * float(width) * band - px * after)


def _names(buffers) -> set:
    names = []
    for name in buffers:
        for n in ALIASES.get(name, (name,)):
            if n not in BUFFER_BYTES:
                raise ValueError(f"buffers: unknown buffer {name!r}; expected some of {', '.join(BUFFER_BYTES)}")
            names.append(n)
    return set(names)


def _samples(samples) -> int:
    if isinstance(samples, bool) or int(samples) != samples or samples < 1:
        raise ValueError(f"samples: expected an integer >= 1, got {samples!r}")
    return int(samples)
