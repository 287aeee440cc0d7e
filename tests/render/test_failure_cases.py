"""The failure catalogue's property test (``docs/failure-cases.md``): random,
degenerate scenes through the whole pipeline, checked against a float64
ray-triangle test (the numbered cases: ``tests/shading/test_failure_cases.py``
and its siblings in ``tests/scene`` and ``tests/visibility``).
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, event, given, settings
from hypothesis import strategies as st

import raycast_shade as rs
from raycast_shade.study import failure_scenes as fs

from tests.conftest import camera_rays


# ==========================================================================================
# Property test: random, degenerate scenes
# ==========================================================================================
def _ray_triangle(o, d, tri):
    """Float64 Moeller-Trumbore of rays (N, 3) against triangles (F, 3, 3).

    Returns t (N, F) (inf where parallel) and the hit point's distance inside
    the triangle (N, F): min over the edges of b_k * height_k, negative
    outside."""
    p0, p1, p2 = tri[:, 0], tri[:, 1], tri[:, 2]
    e1, e2 = p1 - p0, p2 - p0
    pv = np.cross(d[:, None, :], e2[None])
    det = fs.dot(e1[None], pv)
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = 1.0 / det
        tv = o[:, None, :] - p0[None]
        b1 = fs.dot(tv, pv) * inv
        qv = np.cross(tv, e1[None])
        b2 = fs.dot(d[:, None, :], qv) * inv
        t = fs.dot(e2[None], qv) * inv
        b0 = 1.0 - b1 - b2
        area2 = np.linalg.norm(np.cross(e1, e2), axis=1)
        heights = [area2 / np.maximum(np.linalg.norm(e, axis=1), 1e-300) for e in (p2 - p1, p2 - p0, p1 - p0)]
        inside = np.minimum(np.minimum(b0 * heights[0], b1 * heights[1]), b2 * heights[2])
    bad = ~np.isfinite(t) | (np.abs(det) < 1e-300)
    t = np.where(bad, np.inf, t)
    inside = np.where(bad, -np.inf, inside)
    return t, inside


finite = dict(allow_nan=False, allow_infinity=False)


@st.composite
def degenerate_scene(draw):
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    scale = draw(st.sampled_from([1e-3, 1.0, 1e3]))
    offset = np.array(draw(st.sampled_from([(0.0, 0.0, 0.0), (1e3, -2e3, 5e2), (1e5, 3e4, -1e5)])))
    nv = draw(st.integers(3, 16))
    kind = draw(st.sampled_from(["random", "lattice", "sliver", "duplicate"]))
    verts = rng.uniform(-1, 1, (nv, 3))
    if kind == "lattice":  # coplanar, collinear and coincident points
        verts = np.round(verts * 2) / 2
    elif kind == "sliver":  # points close to a line: long, thin triangles
        verts[:, 1:] *= 10.0 ** rng.uniform(-7, -2)
    elif kind == "duplicate":  # repeated positions, unwelded
        verts = verts[rng.integers(0, max(2, nv // 3), nv)]
    faces = rng.integers(0, nv, (draw(st.integers(1, 24)), 3))
    if draw(st.booleans()):
        sel = rng.random(len(faces)) < 0.3
        faces[sel, 2] = faces[sel, 1]  # repeated indices
    verts = verts * scale + offset
    if draw(st.booleans()):
        normals = rng.normal(size=(nv, 3))
        normals[rng.random(nv) < 0.25] = 0.0
        normals[rng.random(nv) < 0.25] *= -1.0
        mesh = rs.Mesh(verts, faces, normals=normals)
    else:
        mesh = rs.Mesh(verts, faces, weighting=draw(st.sampled_from(["uniform", "area", "angle"])),
                       crease_angle=draw(st.one_of(st.none(), st.floats(1.0, 180.0))))
    material = rs.Material(kd=tuple(rng.uniform(0, 1, 3)), ka=draw(st.floats(0, 1)), ks=tuple(rng.uniform(0, 2, 3)),
                           shininess=float(10.0 ** draw(st.floats(-0.3, 6.0))),
                           specular=draw(st.sampled_from(["phong", "blinn"])))
    lights = []
    for _ in range(draw(st.integers(0, 3))):
        where = draw(st.sampled_from(["free", "vertex", "centroid", "directional"]))
        shadows = draw(st.booleans())
        if where == "directional":
            d = rng.normal(size=3)
            lights.append(rs.DirectionalLight(d, intensity=draw(st.floats(0, 10)), shadows=shadows))
            continue
        if where == "vertex":
            pos = verts[rng.integers(nv)]
        elif where == "centroid":
            pos = verts[faces[rng.integers(len(faces))]].mean(axis=0)
        else:
            pos = rng.uniform(-2, 2, 3) * scale + offset
        lights.append(rs.PointLight(pos, intensity=draw(st.floats(0, 10)), shadows=shadows,
                                    attenuation=draw(st.sampled_from(["none", "inverse_square", "heuristic"])),
                                    k=draw(st.floats(1e-3, 5.0)) * scale))
    eye = rng.normal(size=3)
    eye = eye / np.linalg.norm(eye) * draw(st.one_of(st.floats(1.5, 5.0), st.floats(0.3, 1.5)))
    target = rng.uniform(-0.3, 0.3, 3)
    up = rng.normal(size=3)
    fwd = fs.unit(target - eye)
    assume(np.linalg.norm(np.cross(fwd, fs.unit(up))) > 1e-3)
    camera = rs.Camera(eye=eye * scale + offset, target=target * scale + offset, up=up, fov=draw(st.floats(20.0, 150.0)),
                       width=draw(st.integers(1, 24)), height=draw(st.integers(1, 18)),
                       projection=draw(st.sampled_from(["perspective", "orthographic"])),
                       ortho_height=draw(st.floats(0.5, 4.0)) * scale)
    background = tuple(rng.uniform(0, 1, 3)) if draw(st.booleans()) else 0.0
    return fs.scene([rs.Model(mesh, material)], lights, camera, ambient=draw(st.floats(0, 1)), background=background)


@pytest.mark.filterwarnings("ignore::raycast_shade.WindingWarning")  # random faces: expected, and tested elsewhere
@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much])
@given(scene=degenerate_scene())
def test_property_random_degenerate_scenes(scene):
    """Random small meshes (random, lattice, sliver and duplicated vertices;
    random faces with repeated indices; given normals with zeros and flips,
    or computed ones with any crease), at scales 1e-3..1e3 and offsets up to
    1e5, random perspective and orthographic cameras, point lights anywhere
    (on vertices, on faces) with any law and shadows, directional lights,
    t from 0.5 to 1e6. Always: finite, non-negative images, the background
    colour exactly where the mask is off, a mask equal to prim >= 0 (and
    geom >= 0), unit normals on the viewer's side of each face, and a mask
    that agrees with a float64 ray-triangle test wherever that test is
    unambiguous (hits inside a face by more than 1e-5 of the scene's size,
    at a distance the ray can resolve)."""
    geo = scene.geometry
    cam = scene.camera
    origins, dirs = camera_rays(cam)
    o = origins.reshape(-1, 3) - geo.origin
    d = dirs.reshape(-1, 3)
    tri = geo.vertices[geo.faces]
    t_ref, inside = _ray_triangle(o, d, tri)
    margin = 1e-5 * geo.scale
    robust = (inside > margin) & (t_ref > margin) & np.isfinite(t_ref)
    near = np.where(robust, t_ref, np.inf).min(axis=1)
    flat_normal = None
    for shading in rs.SHADINGS:
        frame = rs.render(scene, shading)
        img = frame.image
        assert img.shape == (cam.height, cam.width, 3)
        assert np.isfinite(img).all()
        assert img.min() >= 0.0
        np.testing.assert_array_equal(frame.mask, frame.hits.prim >= 0)
        np.testing.assert_array_equal(frame.hits.geom >= 0, frame.mask)
        np.testing.assert_array_equal(img[~frame.mask], np.broadcast_to(np.asarray(scene.background, np.float32),
                                                                         img[~frame.mask].shape))
        hit = frame.mask.reshape(-1)
        event(f"coverage: {'some' if hit.any() else 'none'}")
        event(f"unambiguous hits: {'some' if np.isfinite(near).any() else 'none'}")
        # Every robust intersection is found; the mask is not wider than the geometry.
        assert hit[np.isfinite(near)].all()
        t = frame.hits.t.reshape(-1).astype(np.float64)
        assert np.isinf(t[~hit]).all()
        if hit.any():
            assert (t[hit] >= 0).all() and np.isfinite(t[hit]).all()
            u = frame.hits.u.reshape(-1)[hit]
            v = frame.hits.v.reshape(-1)[hit]
            assert (u >= -1e-6).all() and (v >= -1e-6).all() and (u + v <= 1 + 1e-6).all()
            # The hit triangle is crossed by the ray (to float32 precision, or by a ray 1e-2 pixel
            # away where the caster re-cast a miss between hits), no farther than the nearest robust hit.
            f = geo.faces[geo.face_offsets[frame.hits.geom.reshape(-1)[hit]] + frame.hits.prim.reshape(-1)[hit]]
            if cam.orthographic:
                pixel = np.full(hit.sum(), cam.ortho_height / cam.height)
            else:
                pixel = t[hit] * 2.0 * np.tan(np.radians(cam.fov) / 2.0) / cam.height
            tol = 1e-3 * geo.scale + 0.05 * pixel
            assert (t[hit] <= near[hit] + tol).all()
            rows = np.flatnonzero(hit)
            _, ins = _ray_triangle(o[rows], d[rows], geo.vertices[f])
            # A re-cast ray starts up to 1e-2 * sqrt(2) pixel from the centre; on a face seen at
            # a grazing angle its hit lands that far / |cos| across the face from the centre ray's.
            tri_f = geo.vertices[f]
            nf = np.cross(tri_f[:, 1] - tri_f[:, 0], tri_f[:, 2] - tri_f[:, 0])
            cos = np.abs(fs.dot(d[rows], nf)) / np.maximum(np.linalg.norm(nf, axis=1), 1e-300)
            assert (np.diagonal(ins) > -(tol + 0.015 * pixel / np.maximum(cos, 1e-6))).all()
        n = frame.normal
        assert np.isfinite(n).all()
        np.testing.assert_allclose(np.linalg.norm(n[frame.mask], axis=-1), 1.0, atol=1e-5)
        if shading == "flat":
            flat_normal = n
        else:
            assert (fs.dot(n, flat_normal)[frame.mask] >= -1e-5).all()

