"""The scenes of the failure catalogue (``docs/failure-cases.md``), built in one place.

Each case of the catalogue provokes a failure of a method on a small scene. The
tests (``tests/*/test_failure_cases.py``) assert on these scenes and the figure
script (``docs/figures/failure_cases.py``) draws and measures them, so a figure
quoted in the catalogue is measured on the scene a test holds to it. Builders are
named by case; nothing here renders (this module sits below ``render`` in the
layer order): callers pass the scenes to ``rs.render``.

Builders that a figure dresses differently (a material with a highlight, a taller
image) take that as an argument whose default is the test's.
"""

from __future__ import annotations

import numpy as np

from ..scene import shapes
from ..scene.camera import Camera
from ..scene.lights import DirectionalLight, PointLight
from ..scene.material import Material
from ..scene.mesh import Mesh
from ..scene.scene import Model, Scene
from ..visibility.rays import camera_frame


# -- small helpers -------------------------------------------------------------------------------------

def dot(a, b):
    """Row-wise dot product of ``(..., 3)`` arrays: ``(...,)``."""
    return np.einsum("...k,...k->...", a, b)


def unit(a):
    """``a`` scaled to unit length along its last axis, float64."""
    a = np.asarray(a, np.float64)
    return a / np.linalg.norm(a, axis=-1, keepdims=True)


def scene(models, lights=(), camera=None, ambient=0.0, background=0.0):
    """A scene of ``models`` (a bare :class:`Mesh` becomes one model with the default material)."""
    if isinstance(models, Mesh):
        models = [Model(models, Material())]
    return Scene(models, lights=list(lights), camera=camera, ambient=ambient, background=background)


def grid_mesh(xs, ys, z=None, normals=None, alternate=True, name="grid"):
    """A height field over the grid ``xs`` x ``ys``, two triangles per cell.

    Parameters
    ----------
    xs : (X,) float
    ys : (Y,) float
    z : float or (X, Y) float, optional
        Heights; 0 when not given.
    normals : (X * Y, 3) float, optional
        Vertex normals, row-major over ``(xs, ys)``; computed when not given.
    alternate : bool
        Flip the diagonal of every other cell (else all cells share one diagonal).

    Returns
    -------
    Mesh
        Counter-clockwise seen from +z.
    """
    X, Y = np.meshgrid(np.asarray(xs, float), np.asarray(ys, float), indexing="ij")
    Z = np.zeros_like(X) if z is None else np.broadcast_to(z, X.shape)
    verts = np.stack([X.ravel(), Y.ravel(), np.asarray(Z, float).ravel()], 1)
    nx, ny = X.shape
    i, j = np.mgrid[0:nx - 1, 0:ny - 1]
    a = (i * ny + j).ravel()
    b, c = a + ny, a + 1
    d = b + 1
    if alternate:
        alt = ((i + j) % 2 == 0).ravel()[:, None]
        f1 = np.where(alt, np.stack([a, b, d], 1), np.stack([a, b, c], 1))
        f2 = np.where(alt, np.stack([a, d, c], 1), np.stack([b, d, c], 1))
    else:
        f1, f2 = np.stack([a, b, d], 1), np.stack([a, d, c], 1)
    return Mesh(verts, np.concatenate([f1, f2]), normals=normals, name=name)


def raw_normals(scene, frame):
    """The normals of a frame's hit pixels before the orientation rule.

    The interpolated vertex normal, renormalised and negated with the face where
    the face is seen from its back (no other orientation).

    Returns
    -------
    raw, g, v, p : (N, 3) float64
        Per hit pixel (row-major): the raw normal, the geometric normal turned to
        the viewer, the unit view vector and the hit point (re-centred).
    """
    geo = scene.geometry
    mask = frame.mask
    face = geo.face_offsets[frame.hits.geom[mask]] + frame.hits.prim[mask]
    tri = geo.faces[face]
    b1 = frame.hits.u[mask].astype(np.float64)
    b2 = frame.hits.v[mask].astype(np.float64)
    bary = np.stack([1 - b1 - b2, b1, b2], 1)
    p = np.einsum("nk,nkc->nc", bary, geo.vertices[tri])
    if scene.camera.orthographic:
        v = np.broadcast_to(-scene.camera.basis[2], p.shape).copy()
    else:
        v = unit(scene.camera.eye - geo.origin - p)
    g = geo.face_normals[face]
    sgn = np.where(dot(g, v) < 0, -1.0, 1.0)
    raw = unit(np.einsum("nk,nkc->nc", bary, geo.normals[tri])) * sgn[:, None]
    return raw, g * sgn[:, None], v, p


# -- 1. Gouraud misses a highlight inside a large triangle; Mach bands -------------------------------------

def highlight_plane_scene(subdivisions=1, kd=0.0):
    """A 4 x 4 square (two triangles unless subdivided) under a point light whose
    highlight lies inside a triangle, far from every vertex; specular only unless ``kd``."""
    mesh = shapes.plane(size=4.0, subdivisions=subdivisions)
    cam = Camera(eye=(0.0, 0.0, 3.0), width=96, height=72, fov=60)
    mat = Material(kd=kd, ka=0.0, ks=1.0, shininess=64)
    return scene([Model(mesh, mat)], [PointLight((0.3, 0.2, 2.0), intensity=1.0)], cam)


def tube(segments, span=0.9 * np.pi, half_height=1.0):
    """A unit-radius part-cylinder around the y axis, facing +z, with exact normals:
    under an orthographic eye on +z its image varies along x only."""
    th = np.linspace(-span / 2, span / 2, segments + 1)
    ring = np.stack([np.sin(th), np.zeros_like(th), np.cos(th)], 1)
    verts = np.concatenate([ring + [0.0, -half_height, 0.0], ring + [0.0, half_height, 0.0]])
    a = np.arange(segments)
    b = a + segments + 1
    faces = np.concatenate([np.stack([a, a + 1, b], 1), np.stack([a + 1, b + 1, b], 1)])
    return Mesh(verts, faces, normals=np.concatenate([ring, ring]), name=f"tube{segments}")


def tube_scene(segments, width=128, height=16):
    """The diffuse tube under a directional light from the upper left, seen orthographically
    so that the image spans x in [-1, 1]. The exact row is
    ``max(0, x s_x + sqrt(1 - x^2) s_z)`` with ``s = -scene.lights[0].direction``."""
    cam = Camera(eye=(0.0, 0.0, 5.0), width=width, height=height, projection="orthographic",
                 ortho_height=2.0 * height / width)
    return scene([Model(tube(segments), Material(kd=1.0, ka=0.0))], [DirectionalLight((-0.5, 0.0, -1.0))], cam)


# -- 2. Flat shading's facets --------------------------------------------------------------------------------

def facet_sphere_scene(level):
    """``icosphere(level)``, diffuse, under a directional light, 96 x 96."""
    cam = Camera(eye=(0.0, 0.0, 4.0), width=96, height=96, fov=35)
    return scene([Model(shapes.icosphere(level), Material(kd=0.7, ka=0.0))],
                 [DirectionalLight((-1.0, -1.0, -2.0))], cam)


# -- 3. Interpolated normals that cancel ------------------------------------------------------------------

def ortho_down(width=64, height=48, ortho_height=2.5):
    """An orthographic camera straight above (0.2, 0.3, 0)."""
    return Camera(eye=(0.2, 0.3, 4.0), target=(0.2, 0.3, 0.0), width=width, height=height,
                  projection="orthographic", ortho_height=ortho_height)


def checker_normals_scene():
    """A 7 x 7 vertex grid in z = 0 whose vertex normals alternate +z and -z (a
    checkerboard), one diagonal per cell, seen from straight above."""
    xs = np.linspace(-1.0, 1.0, 7)
    sign = np.where((np.add.outer(np.arange(7), np.arange(7)) % 2) == 0, 1.0, -1.0).ravel()
    normals = np.zeros((49, 3))
    normals[:, 2] = sign
    grid = grid_mesh(xs, xs, normals=normals, alternate=False)
    return scene([Model(grid, Material(kd=0.7, ks=0.5, shininess=10))],
                 [DirectionalLight((-0.3, -0.2, -1.0))], ortho_down(), ambient=0.1)


def zero_normals_scene():
    """``icosphere(2)`` with vertex normals of exactly zero, orthographic eye, directional light."""
    sphere = shapes.icosphere(2)
    mesh = Mesh(sphere.vertices, sphere.faces, normals=np.zeros_like(sphere.vertices))
    cam = Camera(eye=(1.0, 2.0, 4.0), width=64, height=48, projection="orthographic", ortho_height=2.4)
    return scene([Model(mesh, Material(kd=0.7, ks=0.5, shininess=10))],
                 [DirectionalLight((-1.0, -2.0, -1.5))], cam, ambient=0.1)


# -- 4. Shading normals facing away from the viewer ----------------------------------------------------------

def silhouette_scene(level):
    """A coarse ``icosphere(level)`` seen from close by (wide angle), lit from above."""
    cam = Camera(eye=(0.0, 0.3, 2.2), width=128, height=96, fov=70)
    mat = Material(kd=0.7, ks=0.5, shininess=20)
    return scene([Model(shapes.icosphere(level), mat)], [PointLight((0.5, 3.0, 0.5), intensity=1.0)], cam,
                 ambient=0.05)


def tipping_field_scene():
    """A 9 x 9 grid in z = 0 whose given vertex normals turn from +z through +x to
    150 degrees from the face normal, seen orthographically from above."""
    xs = np.linspace(-1.0, 1.0, 9)
    X, _ = np.meshgrid(xs, xs, indexing="ij")
    angle = np.radians(75.0 * (X.ravel() + 1.0))  # 0 .. 150 degrees
    normals = np.stack([np.sin(angle), np.zeros_like(angle), np.cos(angle)], 1)
    cam = Camera(eye=(0.0, 0.0, 4.0), width=96, height=72, projection="orthographic", ortho_height=2.0)
    return scene([Model(grid_mesh(xs, xs, normals=normals), Material(kd=0.8))],
                 [DirectionalLight((-1.0, 0.0, -1.0))], cam)


# -- 5. Averaged normals across hard creases -------------------------------------------------------------

def cube_scene(crease):
    """A cube of side 1.5 whose normals are averaged up to ``crease`` degrees, orthographic."""
    cam = Camera(eye=(3.0, 2.5, 4.0), width=96, height=72, projection="orthographic", ortho_height=2.4)
    cube = shapes.cube(size=1.5, crease_angle=crease)
    return scene([Model(cube, Material(kd=0.7, ks=0.4, shininess=16))],
                 [DirectionalLight((-1.0, -2.0, -3.0), intensity=0.8)], cam, ambient=0.1)


def cylinder_scene(crease, material=None, ambient=0.0):
    """A 16-sided capped cylinder (radius 0.5, height 1) with normals averaged up to ``crease``."""
    cam = Camera(eye=(1.2, 1.4, 2.0), target=(0.0, 0.0, 0.0), width=96, height=72, fov=40)
    mesh = shapes.cylinder(radius=0.5, height=1.0, segments=16, crease_angle=crease)
    return scene([Model(mesh, material or Material(kd=0.7))], [DirectionalLight((-1.0, -2.0, -1.0))], cam,
                 ambient=ambient)


def ideal_cylinder_normals(points, half_height=0.5):
    """Exact normals of the capped cylinder of radius 0.5 along y at ``points`` (N, 3):
    the axis on the caps, radial on the side."""
    n = np.zeros_like(points)
    cap = np.abs(np.abs(points[:, 1]) - half_height) < 1e-6
    n[cap, 1] = np.sign(points[cap, 1])
    n[~cap] = unit(points[~cap] * [1.0, 0.0, 1.0])
    return n


# -- 6. Degenerate and sliver triangles, duplicate vertices, inconsistent winding --------------------------

LAMP = (PointLight((0.5, 0.8, 1.5), intensity=2.0, attenuation="inverse_square"),)
LAMP_CAMERA = Camera(eye=(0.2, -0.3, 3.0), target=(0.0, 0.0, 0.0), width=96, height=72, fov=50)
SHINY = Material(kd=0.7, ks=0.5, shininess=30)
SPHERE_CAMERA = Camera(eye=(0.0, 0.5, 3.5), width=96, height=72, fov=40)


def lamp_scene(mesh, camera=LAMP_CAMERA):
    """``mesh`` in a shiny material under a near inverse-square lamp."""
    return scene([Model(mesh, SHINY)], LAMP, camera, ambient=0.05)


def sliver_fan(n):
    """The square [-1, 1]^2 in z = 0 as a fan of ``n`` slivers from the corner
    (-1, 1) to n + 1 points on the bottom edge, plus one closing triangle."""
    xs = np.linspace(-1.0, 1.0, n + 1)
    verts = np.vstack([np.stack([xs, -np.ones_like(xs), np.zeros_like(xs)], 1), [[-1.0, 1.0, 0.0], [1.0, 1.0, 0.0]]])
    faces = [[i, i + 1, n + 1] for i in range(n)] + [[n, n + 2, n + 1]]
    return Mesh(verts, faces, name=f"fan{n}")


def flipped_sphere(fraction=0.3, seed=1, normals=False):
    """``icosphere(3)`` with a random ``fraction`` of its faces wound clockwise.

    Returns
    -------
    ico : Mesh
        The consistent sphere.
    flipped : Mesh
        The same vertices with the chosen faces reversed (and the exact normals if ``normals``).
    selected : (F,) bool
        The reversed faces.
    """
    ico = shapes.icosphere(3)
    rng = np.random.default_rng(seed)
    faces = ico.faces.copy()
    sel = rng.random(len(faces)) < fraction
    faces[sel] = faces[sel][:, ::-1]
    return ico, Mesh(ico.vertices, faces, normals=ico.normals if normals else None), sel


def sphere_scene(mesh):
    """``mesh`` (a unit sphere) with a highlight under one point light, seen from the front."""
    return scene([Model(mesh, Material(kd=0.7, ks=0.4, shininess=20))],
                 [PointLight((2.0, 3.0, 4.0), intensity=1.0)], SPHERE_CAMERA, ambient=0.05)


# -- 7. Extreme shininess -----------------------------------------------------------------------------------

def shininess_scene(shininess, specular="phong"):
    """``icosphere(3)`` with the given shininess under a directional light from the side."""
    mat = Material(kd=0.5, ka=1.0, ks=1.0, shininess=shininess, specular=specular)
    cam = Camera(eye=(0.0, 0.0, 4.0), width=64, height=48, fov=40)
    return scene([Model(shapes.icosphere(3), mat)], [DirectionalLight((-1.0, -0.2, 0.3))], cam, ambient=0.1)


def needle_scene():
    """A 4 x 4 grid plane with t = 1e6, whose mirror point of the light is both the
    centre pixel's centre and a vertex of the mesh."""
    cam = Camera(eye=(0.0, 0.0, 3.0), width=65, height=49, fov=30)
    mat = Material(kd=0.0, ka=0.0, ks=1.0, shininess=1e6)
    return scene([Model(shapes.plane(4.0, 4), mat)], [PointLight((0.0, 0.0, 3.0))], cam)


# -- 8. A point light on a vertex or inside the mesh -------------------------------------------------------

LIGHT_SPHERE = shapes.icosphere(2)
LIGHT_VERTEX = 5
OUTSIDE_CAMERA = Camera(eye=LIGHT_SPHERE.vertices[LIGHT_VERTEX] * 3.0 + [0.3, 0.2, 0.0], target=(0.0, 0.0, 0.0),
                        width=64, height=48, fov=45)
INSIDE_CAMERA = Camera(eye=(0.1, 0.2, 0.3), target=(0.0, 0.0, -1.0), width=64, height=48, fov=100)


def light_positions():
    """Where case 8 puts the light: ``{"inside": ..., "centroid": ..., "vertex": ...}``, (3,) float."""
    ico = LIGHT_SPHERE
    return {"inside": np.array([0.2, -0.1, 0.3]), "centroid": ico.vertices[ico.faces[7]].mean(0),
            "vertex": ico.vertices[LIGHT_VERTEX]}


def light_sphere_scene(position, attenuation, shadows=False):
    """``LIGHT_SPHERE`` under a point light at ``position``, seen from outside (``OUTSIDE_CAMERA``)."""
    light = PointLight(position, intensity=2.0, attenuation=attenuation, k=0.5, shadows=shadows)
    return scene([Model(LIGHT_SPHERE, Material(kd=0.7, ks=0.5, shininess=20))], [light], OUTSIDE_CAMERA,
                 ambient=0.1)


# -- 9. Rays through exact vertices and edges; rays from inside a closed mesh --------------------------------

def pixel_grid_scene(step, offset=(0.0, 0.0)):
    """A flat grid whose vertices sit exactly on pixel centres every ``step`` pixels
    (shifted by ``offset`` pixels), under an orthographic 128 x 96 eye with a
    power-of-two pixel pitch."""
    w, h, pitch = 128, 96, 1.0 / 32.0
    xs = (np.arange(-step, w + step, step) + 0.5 - w / 2 + offset[0]) * pitch
    ys = (np.arange(-step, h + step, step) + 0.5 - h / 2 + offset[1]) * pitch
    cam = Camera(eye=(0.0, 0.0, 5.0), width=w, height=h, projection="orthographic", ortho_height=h * pitch)
    return scene(grid_mesh(xs, ys), [DirectionalLight((0.0, 0.0, -1.0))], cam)


def grid_at_pixel_rays(camera, step):
    """A grid in z = 0 whose vertices lie where the pixel rays of ``camera`` (every
    ``step`` pixels, one step beyond the image) meet the plane, so that each ray passes,
    to rounding, through a vertex or an edge. The camera must look down at z = 0."""
    w, h = camera.width, camera.height
    cf = camera_frame(camera)
    x = np.arange(-step, w + step + 1, step)
    y = np.arange(-step, h + step + 1, step)
    X, Y = np.meshgrid(x, y, indexing="ij")
    sx = 2.0 * (X + 0.5) / w - 1.0
    sy = 1.0 - 2.0 * (Y + 0.5) / h
    d = unit(cf[9:12] + sx[..., None] * cf[3:6] + sy[..., None] * cf[6:9])
    t = -cf[2] / d[..., 2]
    if not (t > 0).all():
        raise ValueError("camera: some pixel rays do not meet the plane z = 0 in front of the eye")
    verts = (cf[0:3] + t[..., None] * d).reshape(-1, 3)
    ny = len(y)
    i, j = np.mgrid[0:len(x) - 1, 0:ny - 1]
    a = (i * ny + j).ravel()
    faces = np.concatenate([np.stack([a, a + ny, a + ny + 1], 1), np.stack([a, a + ny + 1, a + 1], 1)])
    return Mesh(verts, faces)


def pixel_ray_camera(eye, fov):
    """The 128 x 96 perspective camera of case 9's grids at pixel rays."""
    return Camera(eye=eye, target=(0.0, 0.2, 0.0), width=128, height=96, fov=fov)


def inside_cameras(mesh, projections=("perspective", "orthographic")):
    """Cameras at the centre of a closed sphere, each looking at one of about 12 of
    its vertices (65 x 49, so the centre pixel's ray passes through the vertex)."""
    out = []
    for vi in range(0, len(mesh.vertices), max(1, len(mesh.vertices) // 12)):
        target = mesh.vertices[vi]
        up = (0.0, 1.0, 0.0) if abs(target[1]) < 0.9 else (1.0, 0.0, 0.0)
        for projection in projections:
            out.append(Camera(eye=(0.0, 0.0, 0.0), target=target, up=up, width=65, height=49, fov=150,
                              projection=projection, ortho_height=0.8))
    return out


# -- 10. The same scene far from the origin ------------------------------------------------------------------

def far_scene(offset, quantise=False):
    """Three models with shadows from two lights, all moved by ``offset`` (3,).

    With ``quantise`` the moved vertices are rounded to float32 first: what a
    renderer that does not re-centre would see."""
    offset = np.asarray(offset, float)

    def at(v):
        w = v + offset
        return w.astype(np.float32).astype(np.float64) if quantise else w

    s = shapes.icosphere(3, radius=0.7, center=(0.0, 0.2, 0.0))
    pl = shapes.plane(4.0, 4, center=(0.0, -0.5, 0.0), normal="+y")
    tor = shapes.torus(0.5, 0.15, 32, 16, center=(1.0, -0.2, 0.3))
    models = [
        Model(Mesh(at(s.vertices), s.faces, normals=s.normals), Material(kd=(0.8, 0.3, 0.2), ks=0.6, shininess=60)),
        Model(Mesh(at(pl.vertices), pl.faces, normals=pl.normals), Material(kd=0.6)),
        Model(Mesh(at(tor.vertices), tor.faces, normals=tor.normals),
              Material(kd=0.5, ks=0.8, shininess=200, specular="blinn")),
    ]
    lights = [PointLight(np.array([1.5, 2.5, 2.0]) + offset, 12.0, attenuation="inverse_square", shadows=True),
              DirectionalLight((-0.5, -1.0, -0.3), 0.4, shadows=True)]
    cam = Camera(eye=np.array([0.5, 1.2, 3.2]) + offset, target=offset + [0.2, -0.1, 0.0], width=96, height=72,
                 fov=50)
    return Scene(models, lights=lights, camera=cam, ambient=0.05)


# -- 11. Grazing view and grazing light ------------------------------------------------------------------

def grazing_light_scene(elevation):
    """A diffuse plane under a directional light ``elevation`` rad above its horizon."""
    cam = Camera(eye=(0.3, -0.2, 3.0), width=32, height=24, fov=60)
    light = DirectionalLight((-np.cos(elevation), 0.0, -np.sin(elevation)))
    return scene([Model(shapes.plane(4.0, 8), Material(kd=0.8, ka=0.0))], [light], cam)


def terminator_scene():
    """``icosphere(3)`` lit from the side: its terminator runs through the middle of the image."""
    cam = Camera(eye=(0.0, 0.0, 4.0), width=96, height=96, fov=35)
    return scene([Model(shapes.icosphere(3), Material(kd=1.0, ka=0.0))], [DirectionalLight((-1.0, 0.0, 0.0))], cam)


def grazing_view_scene(degrees, projection="perspective"):
    """The eye ``degrees`` above a 4 x 4 plane, zoomed so that the plane fills the image."""
    e = np.radians(degrees)
    h = 4.0 * np.sin(e) * 1.25
    cam = Camera(eye=(0.0, -3.0 * np.cos(e), 3.0 * np.sin(e)), up=(0.0, 0.0, 1.0), width=64, height=48,
                 fov=np.degrees(2 * np.arctan(h / 6.0)), projection=projection, ortho_height=h)
    return scene([Model(shapes.plane(4.0, 8), Material(kd=0.8, ks=0.5, shininess=20))],
                 [PointLight((0.5, 0.5, 1.0))], cam, ambient=0.05)


def specular_switch_scene(elevation):
    """A specular plane under a light ``elevation`` rad above its horizon (from -x),
    seen from the mirror direction of a grazing light (0.5 degrees up)."""
    e_eye = np.radians(0.5)
    cam = Camera(eye=(3.0 * np.cos(e_eye), 0.0, 3.0 * np.sin(e_eye)), up=(0.0, 0.0, 1.0), width=33, height=25,
                 fov=2.0)
    light = DirectionalLight((np.cos(elevation), 0.0, -np.sin(elevation)))
    return scene([Model(shapes.plane(4.0, 2), Material(kd=0.0, ka=0.0, ks=0.5, shininess=20))], [light], cam)
