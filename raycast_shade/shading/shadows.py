"""Shadow rays: a per-task ray buffer, the offset origin, and the occlusion query.

Shadow rays start at the shading point pushed off the surface along the
geometric normal by a few hundred float32 ulps of its coordinates (Wachter
and Binder, Ray Tracing Gems ch. 6), and near zero by a fixed fraction of the
scene's size (their absolute constants, in units of the scene), so the offset
scales with the scene; point-light rays stop just short of the light. Mirror
rays start from the same kind of offset point (:mod:`.mirrors`).

Embree reads the ray through a raw address. That address is computed from
the buffer in the very expression that calls Embree, and the buffer is read
again after the call, so the array is live while Embree uses it whatever
Numba's liveness analysis or parfor hoisting does with locals.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ..visibility import embree
from .jit import CALLED, HELPER

__all__ = []

_SHADOW_TFAR = 1.0 - 1e-5  # point-light shadow rays stop just short of the light
_SCRATCH = 2 * embree.RAY_SLOTS  # float32 slots: one RTCRay plus alignment slack


@njit(**CALLED)  # allocates: NRT on
def _scratch():
    """A per-task RTCRay buffer: (float view, uint view, 16-byte aligned offset in slots)."""
    buf = np.empty(_SCRATCH, np.float32)
    base = buf.ctypes.data
    off = ((16 - base % 16) % 16) // 4
    return buf, buf.view(np.uint32), off


@njit(**HELPER)
def _nudge(p, n, unit):
    """Move coordinate ``p`` by 256 float32 ulps along normal component ``n``.

    Near zero, where ulps vanish but the triangles around the point still
    carry the float32 error of their (larger) vertex coordinates, the move is
    ``unit / 65536`` instead: Wachter and Binder's constants (1/32, 1/65536)
    measured in ``unit``, the scene's size (bounding-box diagonal), rather
    than in absolute units, so that a scene at scale 1e5 is as safe as one
    at scale 1."""
    if abs(p) < unit * (1.0 / 32.0):
        return p + n * (unit * (1.0 / 65536.0))
    _, e = math.frexp(p)
    return p + n * math.ldexp(256.0, e - 24)


@njit(**HELPER)
def _occluded(handle, S, o, g, s, target, is_point, unit):
    """True if the scene blocks the way from ``o`` towards the light.

    ``o`` is the shading point's shadow origin, pushed off the surface along its
    geometric normal ``g`` (on the side of the unit direction ``s`` to the light);
    a point light's ray ends just short of ``target``, its position, a light at
    infinity's (``is_point`` False) goes on along ``s``. ``S`` is the scratch from
    :func:`_scratch`, unpacked only here: shadow rays are the rare path, and the
    unpacking costs reference counting."""
    buf, ib, off = S
    px, py, pz = o
    gx, gy, gz = g
    sx, sy, sz = s
    side = 1.0 if gx * sx + gy * sy + gz * sz >= 0.0 else -1.0
    ox = _nudge(px, side * gx, unit)
    oy = _nudge(py, side * gy, unit)
    oz = _nudge(pz, side * gz, unit)
    if is_point:
        dx = target[0] - ox
        dy = target[1] - oy
        dz = target[2] - oz
        tfar = _SHADOW_TFAR
    else:
        dx = sx
        dy = sy
        dz = sz
        tfar = np.inf
    embree.write_ray(buf, ib, off, 1, (ox, oy, oz), (dx, dy, dz), 0.0, tfar)
    embree.occluded1(handle, buf.ctypes.data + off * 4, 0)  # the address taken from the live array, here
    return buf[off + embree.RAY_TFAR] < 0.0  # Embree sets tfar to -inf on a hit
