"""Shading a hit buffer: flat, Gouraud and Phong, one method per model.

Every method evaluates the reflectance equation (:mod:`.illumination`); what
differs is *where*: once per triangle (:mod:`.flat`), at each vertex
(:mod:`.gouraud`) or at each pixel (:mod:`.phong`). Shadows follow the same
rule: a shadow ray leaves the point where the model is evaluated (face
centre, vertex, or pixel), so Gouraud's shadows are as coarse as its
highlights.

Kernels are private, parallel, and work in float64; their plain-NumPy twins
live in :mod:`raycast_shade.study.reference`.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from ..common.choices import SHADINGS
from ..visibility.hits import check_hits
from .flat import _FLAT, _FLAT_TEX, _lookup_flat_kernel
from .gouraud import _INTERPOLATE, _INTERPOLATE_TEX, _VERTICES, _VERTICES_TEX
from .inputs import kernel_inputs
from .jit import JIT
from .phong import _PHONG, _PHONG_TEX
from .texture import variant_for

__all__ = ["SHADINGS", "METHODS", "shade", "shade_hits", "resolve_methods"]

METHODS = {"flat": 0, "gouraud": 1, "phong": 2}


def resolve_methods(scene, shading) -> np.ndarray:
    """Per-model method codes from a name or one name per model.

    Parameters
    ----------
    shading : str or sequence of str
        ``"flat"``, ``"gouraud"`` or ``"phong"`` for every model, or one of
        those per model (in ``scene.models`` order).

    Returns
    -------
    (G,) int8
        0 flat, 1 Gouraud, 2 Phong.
    """
    n = len(scene.models)
    if isinstance(shading, str):
        names = [shading] * n
    else:
        try:
            names = list(shading)
        except TypeError:
            raise ValueError(
                f"shading: expected one of {list(SHADINGS) + ['auto']} or one per model, got {shading!r}"
            ) from None
        if len(names) != n:
            raise ValueError(f"shading: expected {n} methods (one per model), got {len(names)}")
    codes = np.empty(n, np.int8)
    for i, name in enumerate(names):
        if not isinstance(name, str) or name.lower() not in METHODS:
            where = "shading" if isinstance(shading, str) else f"shading[{i}]"
            raise ValueError(f"{where}: expected one of {list(SHADINGS)}, got {name!r}")
        codes[i] = METHODS[name.lower()]
    return codes


def shade(scene, camera, hits, shading="phong") -> np.ndarray:
    """Shade a hit buffer.

    Parameters
    ----------
    scene : Scene
    camera : Camera
    hits : HitBuffer
    shading : {"flat", "gouraud", "phong"} or sequence of them
        One method for all models, or one per model.

    Returns
    -------
    image : (H, W, 3) float32
        Linear RGB; ``scene.background`` where nothing was hit.

    Raises
    ------
    TypeError, ValueError
        For a hit buffer that does not fit the scene
        (:func:`~raycast_shade.visibility.hits.check_hits`), before any kernel runs.
    """
    _check_inputs(scene, camera, hits)
    return shade_hits(scene, camera, hits, shading)


def _check_inputs(scene, camera, hits) -> None:
    """Types, and a hit buffer whose indices fit the scene. Any shape of buffer is
    fine (the camera supplies the eye, not pixel positions); its indices are not."""
    from ..scene.camera import Camera
    from ..scene.scene import Scene

    if not isinstance(scene, Scene):
        raise TypeError(f"scene: expected a Scene, got {type(scene).__name__}")
    if not isinstance(camera, Camera):
        raise TypeError(f"camera: expected a Camera, got {type(camera).__name__}")
    check_hits(hits, scene.geometry)


@njit(parallel=True, **JIT)
def _visible_kernel(prim, geom, faces, face_off, modes, face_flags, vertex_flags):
    """Mark the faces of flat-shaded models and the vertices of Gouraud-shaded
    ones that some pixel sees: only those get shaded."""
    h, w = prim.shape
    for y in prange(h):
        for x in range(w):
            p = prim[y, x]
            if p >= 0:
                g = geom[y, x]
                f = face_off[g] + p
                # Racy, but every writer stores the same 1.
                if modes[g] == 0:
                    face_flags[f] = 1
                elif modes[g] == 1:
                    vertex_flags[faces[f, 0]] = 1
                    vertex_flags[faces[f, 1]] = 1
                    vertex_flags[faces[f, 2]] = 1


def shade_hits(scene, camera, hits, shading="phong") -> np.ndarray:
    """:func:`shade` without the hit-buffer check, for buffers made by this package's casters and
    rasterizer (valid by construction; a hand-made buffer with bad indices would crash a kernel)."""
    modes = resolve_methods(scene, shading)
    k = kernel_inputs(scene, camera)
    geo = scene.geometry
    h, w = hits.shape
    image = np.empty((h, w, 3), np.float32)
    flat, gouraud = bool(np.any(modes == 0)), bool(np.any(modes == 1))
    if flat or gouraud:
        face_flags = np.zeros(len(geo.faces) if flat else 1, np.uint8)
        vertex_flags = np.zeros(len(geo.vertices) if gouraud else 1, np.uint8)
        _visible_kernel(hits.prim, hits.geom, geo.faces, k["face_off"], modes, face_flags, vertex_flags)
    # Each pixel kernel writes only the pixels of its own method's models
    # (and the background), so a mixed frame runs just the kernels it needs.
    if flat:
        fcol = np.zeros((len(geo.faces), 3), np.float64)
        variant_for(_FLAT, _FLAT_TEX, k)(face_flags, k["G"], geo.face_model, k["materials"], k["cam"], k["L"],
                                         k["T"], geo.uvs, fcol)
        _lookup_flat_kernel(hits.prim, hits.geom, k["face_off"], fcol, k["background"], modes, image)
    if gouraud:
        vcol = np.zeros((len(geo.vertices), 2, 3), np.float64)
        vspec = np.zeros((len(geo.vertices) if k["tex_on"] else 1, 2, 3), np.float64)  # modulate path only
        variant_for(_VERTICES, _VERTICES_TEX, k)(vertex_flags, k["G"], geo.vertex_model, k["materials"], k["cam"],
                                                 k["L"], k["T"], vcol, vspec)
        variant_for(_INTERPOLATE, _INTERPOLATE_TEX, k)(hits.prim, hits.geom, hits.u, hits.v, k["G"], k["B"],
                                                       k["face_off"], k["materials"], k["cam"], k["L"], k["T"],
                                                       k["background"], modes, vcol, vspec, image)
    if np.any(modes == 2):
        variant_for(_PHONG, _PHONG_TEX, k)(hits.prim, hits.geom, hits.u, hits.v, k["G"], k["B"], k["L"], k["T"],
                                           k["face_off"], k["materials"], k["cam"], k["background"], modes, image)
    return image
