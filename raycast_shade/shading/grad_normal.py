"""Back through the Phong shading normal's interpolation: :func:`_normal_vjp`.

:func:`~raycast_shade.shading.surface._shading_normal` interpolates the vertex normals,
renormalises and orients the result into the viewer's hemisphere; its VJP takes ``dL/dn`` to
``dL/da`` of the interpolated (unnormalised) normal, which the drivers spread onto the corners by
the barycentrics (:mod:`.grad_frame`, and through the bent normal :mod:`.grad_bump`).
"""

from __future__ import annotations

from numba import njit

from .jit import HELPER
from .records import dot
from .surface import _CANCEL, interpolated_normal

__all__ = []


@njit(**HELPER)
def _normal_vjp(normals, tri, b1, b2, g, sgn, gn):
    """Back through :func:`~raycast_shade.shading.surface._shading_normal`: ``dL/da`` for the
    interpolated (unnormalised) normal ``a``, given ``dL/dn``; zero where ``a`` cancelled."""
    ax, ay, az, al = interpolated_normal(normals, tri, b1, b2)
    if not al >= _CANCEL:
        return 0.0, 0.0, 0.0
    u = (ax / al, ay / al, az / al)
    m = (sgn * u[0], sgn * u[1], sgn * u[2])
    gx, gy, gz = gn
    c = dot(m, g)
    if c < 0.0:  # reflected into the viewer's hemisphere: n = m - 2 (m.g) g
        k = 2.0 * (gx * g[0] + gy * g[1] + gz * g[2])
        gx, gy, gz = gx - k * g[0], gy - k * g[1], gz - k * g[2]
    q = gx * u[0] + gy * u[1] + gz * u[2]
    w = sgn / al
    return w * (gx - q * u[0]), w * (gy - q * u[1]), w * (gz - q * u[2])
