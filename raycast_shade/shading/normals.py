"""The normal each pixel is shaded with, as an image (``Frame.normal``)."""

from __future__ import annotations

import numpy as np
from numba import njit

from ..common.parallel import in_parts, share
from ..common.layout import METHOD_FLAT, METHOD_PHONG
from ..common.schedule import BLOCK_ROWS, spread_step
from ..visibility.rays import camera_frame
from .inputs import bump_tuple, extensions
from .jit import JIT
from .phong import _surface
from .records import At
from .shade import _check_inputs, resolve_methods

__all__ = ["shading_normals", "normal_inputs", "normals_into"]


@in_parts
@njit(nogil=True, **JIT)
def _normals_kernel(prim, geom, u, v, G, B, face_off, cam, modes, nbuf, part):
    """The unit normal each pixel is shaded with, turned to the viewer."""
    h, w = prim.shape
    nblk = (h + BLOCK_ROWS - 1) // BLOCK_ROWS
    step = spread_step(nblk)
    for it in range(*share(nblk, part)):  # this part's blocks of rows, in a balanced order
        blk = (it * step) % nblk
        for y in range(blk * BLOCK_ROWS, min(h, (blk + 1) * BLOCK_ROWS)):
            for x in range(w):
                p = prim[y, x]
                if p < 0:
                    for c in range(3):
                        nbuf[y, x, c] = 0.0
                    continue
                gm = geom[y, x]
                hp = _surface(G, B, cam, At(face_off[gm] + p, gm, np.float64(u[y, x]), np.float64(v[y, x])),
                              np.bool_(False), (0.0, 0.0, 0.0))
                n = hp.g if modes[gm] == METHOD_FLAT else hp.n
                nbuf[y, x, 0] = n[0]
                nbuf[y, x, 1] = n[1]
                nbuf[y, x, 2] = n[2]


def shading_normals(scene, camera, hits, shading="phong") -> np.ndarray:
    """The normal each pixel is shaded with.

    Parameters
    ----------
    shading : {"flat", "gouraud", "phong"} or sequence of them (one per model)

    Returns
    -------
    (H, W, 3) float32
        Unit normals turned to the viewer (flat: the face normal; otherwise
        the interpolated, renormalised vertex normal, bumped in Phong mode);
        zero on the background.

    Raises
    ------
    TypeError, ValueError
        As :func:`~raycast_shade.shading.shade.shade`, before any kernel runs.
    """
    _check_inputs(scene, camera, hits)
    nbuf = np.empty(hits.shape + (3,), np.float32)
    normals_into(normal_inputs(scene, camera, shading), hits, nbuf)
    return nbuf


def normal_inputs(scene, camera, shading="phong") -> tuple:
    """The shading-normal kernel's inputs of one frame, packed once for every band
    (:func:`normals_into`)."""
    modes = resolve_methods(scene, shading)
    geo = scene.geometry
    # Bumps only apply where the normal is per pixel.
    bump_index = np.where(modes == METHOD_PHONG, geo.bump_index, -1).astype(np.int32)
    nmap_index = np.where(modes == METHOD_PHONG, geo.nmap_index, -1).astype(np.int32)
    B = bump_tuple(geo, bump_index, nmap_index, extensions(scene.packed_lights(), geo.materials, nmap_index,
                                                           geo.textured))
    return ((geo.vertices, geo.normals, geo.faces, geo.face_normals), B, geo.face_offsets,
            camera_frame(camera, geo.origin), modes)


def normals_into(inputs, hits, out) -> None:
    """:func:`shading_normals` of a hit buffer made by this package's casters (valid by
    construction: unchecked) into ``out``, (h, W, 3) float32 (a band's rows of a frame)."""
    G, B, face_off, cam, modes = inputs
    _normals_kernel(hits.prim, hits.geom, hits.u, hits.v, G, B, face_off, cam, modes, out)
