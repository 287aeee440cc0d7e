"""Exact images of analytic surfaces: the ground truth of the accuracy benchmark.

Each pixel's ray (the same ray as the renderer's: :func:`raycast_shade.visibility.rays.pixel_ray`,
pixel centres at ``+0.5``) is intersected with the *surface itself*, not a
tessellation of it, and shaded in float64 at the exact hit point with the
exact normal:

sphere
    closed-form ray-sphere roots (the cancellation-free form
    ``q = -(b + sign(b) sqrt(b^2 - c))``, roots ``q`` and ``c / q``);
    normal ``(p - c) / R``.
torus
    around the ``y`` axis like :func:`raycast_shade.shapes.torus`. The ray is
    clipped to the bounding sphere of radius ``R + r``, then marched with the
    torus's exact signed distance ``sqrt((rho - R)^2 + y^2) - r`` (sphere
    tracing never steps past the first root), and refined by Newton steps
    on that distance once close; the hit is accepted when the distance is
    below ``1e-12`` of the scene's size. Normal ``(p - R rho_hat) / r``.
plane
    a square of side ``size`` facing an axis, like :func:`raycast_shade.shapes.plane`.

The reflectance model is *not* written again here: the hit points, exact
normals and view vectors are handed to the library's own per-point NumPy
evaluation, :func:`raycast_shade.study.reference.illuminate_reference` (the
float64 twin the test suite checks the Numba kernels against), so the ground
truth is plain IEEE float64 with no fast-math. The normal is turned to the
viewer (two-sided lighting), like the geometric normal in
:mod:`raycast_shade.shading`.

Not modelled, and refused with a ``ValueError`` rather than silently
ignored: shadow rays (``shadows=True`` lights), mirror reflection
(``reflectivity > 0``) and bump maps.

>>> import raycast_shade as rs
>>> from raycast_shade.study.analytic import Sphere, render_exact
>>> cam = rs.Camera(eye=(0, 0, 4), width=64, height=48)
>>> ref = render_exact([(Sphere(), rs.Material(ks=0.5, shininess=64))], cam,
...                    lights=[rs.DirectionalLight((0, 0, -1))])
>>> ref.image.shape, ref.mask.shape
((48, 64, 3), (48, 64))
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np
from numba import njit

from ..common.parallel import in_parts, share
from ..common.validate import as_rgb, as_scalar, as_vec3
from ..scene.camera import Camera
from ..scene.lights import AreaLight, DirectionalLight, PointLight
from .reference import spot_cone
from ..scene.material import Material
from ..visibility.rays import camera_frame, pixel_ray

__all__ = ["Sphere", "Torus", "Plane", "ExactFrame", "render_exact", "exact_for_scene", "intersect"]

_SPHERE, _TORUS, _PLANE = 0, 1, 2
_AXES = {"x": 0, "y": 1, "z": 2}



# -- surfaces ---------------------------------------------------------------------------

@dataclass(frozen=True, eq=False)
class Sphere:
    """A sphere of ``radius`` about ``center``.

    Parameters
    ----------
    center : (3,) float
    radius : float
        ``> 0``.
    """

    center: np.ndarray = (0.0, 0.0, 0.0)
    radius: float = 1.0

    def __post_init__(self):
        object.__setattr__(self, "center", as_vec3(self.center, "sphere.center"))
        object.__setattr__(self, "radius", as_scalar(self.radius, "sphere.radius", minimum=0.0, exclusive=True))

    def packed(self) -> np.ndarray:
        """(8,) float64 kernel row: kind, centre(3), radius, 0, 0, 0."""
        return np.array([_SPHERE, *self.center, self.radius, 0.0, 0.0, 0.0])

    @property
    def bounds(self) -> np.ndarray:
        """(2, 3) float64 axis-aligned bounding box."""
        return np.stack([self.center - self.radius, self.center + self.radius])


@dataclass(frozen=True, eq=False)
class Torus:
    """A torus around the ``y`` axis through ``center`` (as :func:`raycast_shade.shapes.torus`).

    Parameters
    ----------
    center : (3,) float
    major_radius, minor_radius : float
        ``major_radius > minor_radius > 0`` (a ring torus).
    """

    center: np.ndarray = (0.0, 0.0, 0.0)
    major_radius: float = 1.0
    minor_radius: float = 0.35

    def __post_init__(self):
        object.__setattr__(self, "center", as_vec3(self.center, "torus.center"))
        big = as_scalar(self.major_radius, "torus.major_radius", minimum=0.0, exclusive=True)
        small = as_scalar(self.minor_radius, "torus.minor_radius", minimum=0.0, exclusive=True)
        if not big > small:
            raise ValueError(f"torus: need major_radius > minor_radius, got {big}, {small}")
        object.__setattr__(self, "major_radius", big)
        object.__setattr__(self, "minor_radius", small)

    def packed(self) -> np.ndarray:
        """(8,) float64 kernel row: kind, centre(3), R, r, 0, 0."""
        return np.array([_TORUS, *self.center, self.major_radius, self.minor_radius, 0.0, 0.0])

    @property
    def bounds(self) -> np.ndarray:
        e = np.array([self.major_radius + self.minor_radius, self.minor_radius, self.major_radius + self.minor_radius])
        return np.stack([self.center - e, self.center + e])


@dataclass(frozen=True, eq=False)
class Plane:
    """A square of side ``size`` facing ``normal`` (as :func:`raycast_shade.shapes.plane`).

    Parameters
    ----------
    center : (3,) float
    size : float
        Side length, ``> 0``.
    normal : {"+x", "-x", "+y", "-y", "+z", "-z"}
    """

    center: np.ndarray = (0.0, 0.0, 0.0)
    size: float = 2.0
    normal: str = "+z"

    def __post_init__(self):
        object.__setattr__(self, "center", as_vec3(self.center, "plane.center"))
        object.__setattr__(self, "size", as_scalar(self.size, "plane.size", minimum=0.0, exclusive=True))
        if self.normal not in {f"{s}{a}" for s in "+-" for a in "xyz"}:
            raise ValueError(f"plane.normal: expected one of +x -x +y -y +z -z, got {self.normal!r}")

    def packed(self) -> np.ndarray:
        """(8,) float64 kernel row: kind, centre(3), size, axis, sign, 0."""
        sign = 1.0 if self.normal[0] == "+" else -1.0
        return np.array([_PLANE, *self.center, self.size, _AXES[self.normal[1]], sign, 0.0])

    @property
    def bounds(self) -> np.ndarray:
        e = np.full(3, self.size / 2)
        e[_AXES[self.normal[1]]] = 0.0
        return np.stack([self.center - e, self.center + e])


SURFACES = (Sphere, Torus, Plane)


# -- the frame ----------------------------------------------------------------------------

@dataclass(frozen=True, eq=False)
class ExactFrame:
    """An exact image and the buffers behind it (the analytic twin of :class:`~raycast_shade.Frame`).

    Attributes
    ----------
    image : (H, W, 3) float64
        Linear RGB; zero on the background.
    mask : (H, W) bool
        Pixels whose ray hits a surface.
    normal : (H, W, 3) float64
        Exact unit normal at the hit, turned to the viewer; zero on the background.
    point : (H, W, 3) float64
        Hit point in world coordinates; zero on the background.
    depth : (H, W) float64
        Ray parameter of the hit (distance along the unit ray; orthographic:
        from the image plane); 0 on the background.
    model_id : (H, W) int32
        Index of the surface hit, ``-1`` on the background.
    camera : Camera
    """

    image: np.ndarray
    mask: np.ndarray
    normal: np.ndarray
    point: np.ndarray
    depth: np.ndarray
    model_id: np.ndarray
    camera: Camera | None = None

    @cached_property
    def luminance(self) -> np.ndarray:
        """(H, W) float64 mean of the three channels."""
        return self.image.mean(axis=2)


# -- kernels ------------------------------------------------------------------------------

@njit(inline="always", cache=True, error_model="numpy")
def _hit_sphere(row, ox, oy, oz, dx, dy, dz):
    """Nearest ``t > 0`` on the sphere, or inf; ``d`` is a unit vector."""
    qx = ox - row[1]
    qy = oy - row[2]
    qz = oz - row[3]
    rad = row[4]
    b = qx * dx + qy * dy + qz * dz
    c = (qx * qx + qy * qy + qz * qz) - rad * rad
    disc = b * b - c
    if disc < 0.0:
        return np.inf
    sq = np.sqrt(disc)
    q = -(b + sq) if b >= 0.0 else -(b - sq)
    if q == 0.0:
        return np.inf
    t0 = q
    t1 = c / q
    if t0 > t1:
        t0, t1 = t1, t0
    if t0 > 0.0:
        return t0
    if t1 > 0.0:
        return t1
    return np.inf


@njit(inline="always", cache=True, error_model="numpy")
def _torus_sdf(px, py, pz, big, small):
    rho = np.sqrt(px * px + pz * pz)
    a = rho - big
    return np.sqrt(a * a + py * py) - small


@njit(inline="always", cache=True, error_model="numpy")
def _torus_normal(px, py, pz, big):
    """Unit outward normal of the torus at (local) ``p``: ``p`` minus its
    nearest point on the core circle, normalised."""
    rho = np.sqrt(px * px + pz * pz)
    if rho > 0.0:
        cx = px - big * px / rho
        cz = pz - big * pz / rho
    else:  # on the axis: not on a ring torus; any radial direction
        cx = px - big
        cz = pz
    cy = py
    ln = np.sqrt(cx * cx + cy * cy + cz * cz)
    if ln == 0.0:
        return 0.0, 1.0, 0.0
    return cx / ln, cy / ln, cz / ln


@njit(cache=True, error_model="numpy")
def _hit_torus(row, ox, oy, oz, dx, dy, dz, tol):
    """Nearest ``t > 0`` on the torus, or inf.

    Bracket with the bounding sphere, sphere-trace with the exact signed
    distance (never past the first root), then Newton on that distance
    once within ``1e-3 r`` at a non-grazing angle; accept ``|sdf| < tol``.
    """
    qx = ox - row[1]
    qy = oy - row[2]
    qz = oz - row[3]
    big = row[4]
    small = row[5]
    rb = big + small
    b = qx * dx + qy * dy + qz * dz
    c = (qx * qx + qy * qy + qz * qz) - rb * rb
    disc = b * b - c
    if disc < 0.0:
        return np.inf
    sq = np.sqrt(disc)
    t_exit = -b + sq
    if t_exit <= 0.0:
        return np.inf
    t = max(-b - sq, 0.0)
    near = 1e-3 * small
    for _ in range(20000):
        px = qx + t * dx
        py = qy + t * dy
        pz = qz + t * dz
        dist = _torus_sdf(px, py, pz, big, small)
        if abs(dist) < near:
            nx, ny, nz = _torus_normal(px, py, pz, big)
            g = nx * dx + ny * dy + nz * dz
            if g < -0.02:  # entering at > ~1 degree: Newton on the distance
                t -= dist / g
                if abs(dist) < tol:  # that was the polishing step
                    return t if t > 0.0 else np.inf
                continue
        if abs(dist) < tol:
            return t if t > 0.0 else np.inf
        t += dist
        if t > t_exit:
            return np.inf
    # Tangent rays that have not converged: a hit only if all but touching.
    px = qx + t * dx
    py = qy + t * dy
    pz = qz + t * dz
    if abs(_torus_sdf(px, py, pz, big, small)) < 1e-7 * small:
        return t
    return np.inf


@njit(inline="always", cache=True, error_model="numpy")
def _hit_plane(row, ox, oy, oz, dx, dy, dz):
    k = int(row[5])
    o = (ox, oy, oz)
    d = (dx, dy, dz)
    c = (row[1], row[2], row[3])
    dk = d[0] if k == 0 else (d[1] if k == 1 else d[2])
    ok = o[0] if k == 0 else (o[1] if k == 1 else o[2])
    ck = c[0] if k == 0 else (c[1] if k == 1 else c[2])
    if dk == 0.0:
        return np.inf
    t = (ck - ok) / dk
    if not t > 0.0:
        return np.inf
    half = 0.5 * row[4]
    for j in range(3):
        if j != k:
            oj = o[0] if j == 0 else (o[1] if j == 1 else o[2])
            dj = d[0] if j == 0 else (d[1] if j == 1 else d[2])
            cj = c[0] if j == 0 else (c[1] if j == 1 else c[2])
            if abs(oj + t * dj - cj) > half:
                return np.inf
    return t


@njit(cache=True, error_model="numpy")
def _intersect(prims, ox, oy, oz, dx, dy, dz, tol):
    """Nearest hit over all surfaces: (t, index), ``(inf, -1)`` on a miss."""
    best = np.inf
    which = -1
    for i in range(prims.shape[0]):
        kind = int(prims[i, 0])
        if kind == _SPHERE:
            t = _hit_sphere(prims[i], ox, oy, oz, dx, dy, dz)
        elif kind == _TORUS:
            t = _hit_torus(prims[i], ox, oy, oz, dx, dy, dz, tol)
        else:
            t = _hit_plane(prims[i], ox, oy, oz, dx, dy, dz)
        if t < best:
            best = t
            which = i
    return best, which


@njit(cache=True, error_model="numpy")
def _normal_at(prims, i, px, py, pz):
    """Unit outward (plane: facing) normal of surface ``i`` at world point ``p``."""
    kind = int(prims[i, 0])
    lx = px - prims[i, 1]
    ly = py - prims[i, 2]
    lz = pz - prims[i, 3]
    if kind == _SPHERE:
        ln = np.sqrt(lx * lx + ly * ly + lz * lz)
        return lx / ln, ly / ln, lz / ln
    if kind == _TORUS:
        return _torus_normal(lx, ly, lz, prims[i, 4])
    k = int(prims[i, 5])
    s = prims[i, 6]
    return (s if k == 0 else 0.0), (s if k == 1 else 0.0), (s if k == 2 else 0.0)


@in_parts
@njit(nogil=True, cache=True, error_model="numpy")
def _exact_kernel(prims, cam, tol, mask, normal, point, depth, model_id, part):
    """Per pixel: nearest hit, its point and the surface's outward normal."""
    h = mask.shape[0]
    w = mask.shape[1]
    for y in range(*share(h, part)):  # this part's share (common.parallel)
        for x in range(w):
            ox, oy, oz, dx, dy, dz = pixel_ray(cam, x, y)
            t, i = _intersect(prims, ox, oy, oz, dx, dy, dz, tol)
            if i < 0:
                mask[y, x] = False
                model_id[y, x] = -1
                depth[y, x] = 0.0
                for c in range(3):
                    normal[y, x, c] = 0.0
                    point[y, x, c] = 0.0
                continue
            px = ox + t * dx
            py = oy + t * dy
            pz = oz + t * dz
            nx, ny, nz = _normal_at(prims, i, px, py, pz)
            mask[y, x] = True
            model_id[y, x] = i
            depth[y, x] = t
            normal[y, x, 0] = nx
            normal[y, x, 1] = ny
            normal[y, x, 2] = nz
            point[y, x, 0] = px
            point[y, x, 1] = py
            point[y, x, 2] = pz


@njit(cache=True, error_model="numpy")
def _intersect_rays_kernel(prims, origins, directions, tol, t_out, id_out):
    for j in range(origins.shape[0]):
        t, i = _intersect(prims, origins[j, 0], origins[j, 1], origins[j, 2],
                          directions[j, 0], directions[j, 1], directions[j, 2], tol)
        t_out[j] = t
        id_out[j] = i


# -- driver -------------------------------------------------------------------------------

def _reference_lights(lights):
    """Lights in the tuple form of :func:`raycast_shade.study.reference.illuminate_reference`:
    ``(directional, vec, radiance (3,), attenuation, k)`` in world coordinates."""
    out = []
    for i, light in enumerate(lights):
        if isinstance(light, DirectionalLight):
            out.append((True, -np.asarray(light.direction, np.float64), light.intensity * light.color, "none", 1.0))
        elif isinstance(light, AreaLight):  # its samples, each 1/N of it (as the kernels)
            out.extend((False, q, light.intensity * light.color / light.samples, light.attenuation, light.k, None)
                       for q in light.sample_points())
        elif isinstance(light, PointLight):
            out.append((False, np.asarray(light.position, np.float64), light.intensity * light.color,
                        light.attenuation, light.k, spot_cone(light)))  # spot_cone: None but for a SpotLight
        else:
            raise TypeError(f"lights[{i}]: expected a PointLight or DirectionalLight, got {type(light).__name__}")
        if getattr(light, "shadows", False):
            raise ValueError(f"lights[{i}]: shadow rays are not modelled by the exact renderer (shadows=True)")
    return out


def _reference_materials(materials):
    """``(ka, kd, ks, shininess, blinn)`` arrays, shapes (G, 3) x 3, (G,), (G,)."""
    for i, m in enumerate(materials):
        if getattr(m, "reflectivity", 0.0) > 0 or getattr(m, "bump", None) is not None:
            raise ValueError(f"models[{i}]: mirror reflection and bump maps are not modelled by the exact renderer")
    return (
        np.array([m.ka for m in materials], np.float64),
        np.array([m.kd for m in materials], np.float64),
        np.array([m.ks for m in materials], np.float64),
        np.array([m.shininess for m in materials], np.float64),
        np.array([m.specular == "blinn" for m in materials], bool),
    )


def _as_models(models):
    out = []
    if isinstance(models, SURFACES) or (isinstance(models, tuple) and len(models) == 2 and isinstance(models[0], SURFACES)):
        models = [models]
    for i, item in enumerate(models):
        if isinstance(item, SURFACES):
            out.append((item, Material()))
        elif isinstance(item, tuple) and len(item) == 2 and isinstance(item[0], SURFACES) and isinstance(item[1], Material):
            out.append(item)
        else:
            raise TypeError(f"models[{i}]: expected a Sphere, Torus or Plane, or a (surface, Material) pair, "
                            f"got {type(item).__name__}")
    if not out:
        raise ValueError("models: at least one surface is needed")
    return out


def _packed(models):
    prims = np.stack([s.packed() for s, _ in models])
    lo = np.min([s.bounds[0] for s, _ in models], axis=0)
    hi = np.max([s.bounds[1] for s, _ in models], axis=0)
    scale = float(max(np.linalg.norm(hi - lo), 1e-30))
    return prims, scale


def render_exact(models, camera: Camera, lights=(), ambient=0.1) -> ExactFrame:
    """Render analytic surfaces exactly.

    Parameters
    ----------
    models : sequence of Sphere, Torus, Plane or (surface, Material) pairs
        A single surface or pair is accepted too.
    camera : Camera
    lights : sequence of PointLight or DirectionalLight
        Without shadows.
    ambient : float or (3,) float
        The scene's ``Ia``.

    Returns
    -------
    ExactFrame
        Float64 buffers of shape (camera.height, camera.width[, 3]).

    Raises
    ------
    TypeError, ValueError
        For a bad argument, or a feature the exact renderer does not model
        (shadows, mirrors, bump maps).
    """
    from .reference import illuminate_reference

    if not isinstance(camera, Camera):
        raise TypeError(f"camera: expected a Camera, got {type(camera).__name__}")
    models = _as_models(models)
    prims, scale = _packed(models)
    ref_lights = _reference_lights(tuple(lights))
    ref_mats = _reference_materials([m for _, m in models])
    amb = np.asarray(as_rgb(ambient, "ambient"), np.float64)
    h, w = camera.height, camera.width
    mask = np.empty((h, w), np.bool_)
    normal = np.empty((h, w, 3))
    point = np.empty((h, w, 3))
    depth = np.empty((h, w))
    model_id = np.empty((h, w), np.int32)
    _exact_kernel(prims, camera_frame(camera), 1e-12 * scale, mask, normal, point, depth, model_id)

    # View vectors, as the renderer's: towards the eye, or against the view
    # direction for an orthographic camera (or a point at the eye itself).
    p = point[mask]
    fwd = camera.basis[2]
    if camera.orthographic:
        v = np.broadcast_to(-fwd, p.shape).copy()
    else:
        v = camera.eye - p
        length = np.linalg.norm(v, axis=1)
        ok = length > 0
        v[ok] /= length[ok, None]
        v[~ok] = -fwd
    n = normal[mask]
    back = np.einsum("ij,ij->i", n, v) < 0.0  # two-sided lighting: turn to the viewer
    n[back] *= -1.0
    normal[mask] = n
    image = np.zeros((h, w, 3))
    if p.size:
        image[mask] = illuminate_reference(p, n, v, model_id[mask], ref_mats, ref_lights, amb, 1e-6 * scale)
    return ExactFrame(image=image, mask=mask, normal=normal, point=point, depth=depth, model_id=model_id,
                      camera=camera)


def exact_for_scene(scene, surfaces, camera: Camera | None = None) -> ExactFrame:
    """The exact image of a tessellated scene: the same materials, lights,
    ambient light and camera, with each model replaced by its analytic surface.

    Parameters
    ----------
    scene : Scene
    surfaces : sequence of Sphere, Torus or Plane
        One per model of ``scene``, in order.
    camera : Camera, optional
        Overrides ``scene.camera``.

    Returns
    -------
    ExactFrame
    """
    if len(surfaces) != len(scene.models):
        raise ValueError(f"surfaces: expected one per model ({len(scene.models)}), got {len(surfaces)}")
    camera = camera if camera is not None else scene.camera
    if camera is None:
        raise ValueError("camera: the scene has no camera and none was passed")
    models = [(s, m.material) for s, m in zip(surfaces, scene.models)]
    return render_exact(models, camera, scene.lights, scene.ambient)


def intersect(models, origins, directions):
    """Nearest hit of arbitrary rays with analytic surfaces.

    Parameters
    ----------
    models : sequence of surfaces or (surface, Material) pairs
    origins, directions : (N, 3) float
        Directions must be unit vectors (``t`` is then a distance).

    Returns
    -------
    t : (N,) float64
        ``inf`` on a miss.
    index : (N,) int32
        Surface index, ``-1`` on a miss.
    """
    models = _as_models(models)
    prims, scale = _packed(models)
    o = np.ascontiguousarray(np.atleast_2d(origins), np.float64)
    d = np.ascontiguousarray(np.atleast_2d(directions), np.float64)
    if o.shape != d.shape or o.shape[1:] != (3,):
        raise ValueError(f"origins and directions: expected matching (N, 3), got {o.shape} and {d.shape}")
    t = np.empty(len(o))
    idx = np.empty(len(o), np.int32)
    _intersect_rays_kernel(prims, o, d, 1e-12 * scale, t, idx)
    return t, idx
