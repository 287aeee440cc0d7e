"""Geometry gradients (vertices, camera pose) on scenes with mesh colours and colour maps
(shading/grad_geotex.py, grad_textured.py) against central finite differences in float64.

The oracle is test_grad_geometry's: each pixel's triangle held, the perturbed scene's exact hits on it
(plain NumPy), shaded by the NumPy twin (``study.reference.shade_reference``, which samples the
same maps and colours). Bilinear filtering is only C0 across a texel cell's edge, so a pixel whose
sample point changes cells between the two perturbed scenes of any checked step gets weight 0 in
the loss (the test says how many). Relative error <= 1e-4 as in test_grad_geometry.py.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import raycast_shade as rs
from raycast_shade.common.layout import TEX_HEIGHT, TEX_TILE_U, TEX_TILE_V, TEX_WIDTH
from raycast_shade.gradients import rotate_camera
from raycast_shade.study.reference import shade_reference

from .test_grad_edges import RTOL as EDGE_RTOL
from .test_grad_edges import STEP as EDGE_STEP
from .test_grad_edges import _camera as edges_camera
from .test_grad_edges import anti_aliased
from .test_grad_geometry import RTOL, STEP, exact_hits
from .test_grad_maps import _scene, _texture

GEOMETRY = ("vertices", "camera_eye", "camera_rotation")


def _textured(kind):
    """``maps``: kd, ks, ka, ke and occlusion maps (bilinear; one clamped); ``vertex``: vertex colours,
    ambient following them, and a kd map; ``vertex-plain``: vertex colours alone (Gouraud's vertex
    path); ``face``: face colours and a ks map."""
    n = rs.shapes.icosphere(2).vertices.shape[0]
    rng = np.random.default_rng(6)
    if kind == "maps":
        return _scene(kd_map=_texture(3, "repeat", (6, 8)), ks_map=_texture(4, "clamp", (5, 7)),
                      ka_map=_texture(5, "repeat", (6, 8)), ao_map=_texture(7, "repeat", (4, 6)),
                      ke_map=_texture(8, "repeat", (3, 5)), ke=(0.3, 0.2, 0.4), ao_strength=0.7)
    if kind == "vertex":
        return _scene(rng.uniform(0.2, 0.9, (n, 3)), "vertex", kd_map=_texture(3, "repeat", (6, 8)))
    if kind == "vertex-plain":
        return _scene(rng.uniform(0.2, 0.9, (n, 3)), "vertex")
    faces = rs.shapes.icosphere(2).faces.shape[0]
    return _scene(rng.uniform(0.2, 0.9, (faces, 3)), "face", ks_map=_texture(4, "repeat", (5, 7)))


def smooth_weights():
    """A smooth loss weight, as test_grad_edges' (a random one makes the anti-aliased loss jump)."""
    cam = edges_camera()
    yy, xx = np.mgrid[0:cam.height, 0:cam.width] + 0.5
    return np.stack([np.cos(0.15 * xx + c) * np.sin(0.11 * yy + 1.0) + 0.5 for c in range(3)], axis=-1)


def _moved_vertex(scene, row, col, delta):
    model = scene.models[0]
    mesh = model.mesh
    verts = np.array(mesh.vertices, float)
    verts[row, col] += delta
    moved = rs.Mesh(verts, mesh.faces, normals=mesh.normals, uvs=mesh.uvs, colors=mesh.colors,
                    color_mode=mesh.color_mode or "auto")
    return scene.replace(models=(dataclasses.replace(model, mesh=moved),))


def _cells(scene, hits):
    """Each pixel's texel cell (floor of its texel coordinates) in every map of the model: (H, W, 2 M)."""
    geo = scene.geometry
    face = geo.face_offsets[np.maximum(hits.geom, 0)] + np.maximum(hits.prim, 0)
    tri = geo.faces[face]
    b = np.stack([1.0 - hits.u - hits.v, hits.u, hits.v], axis=-1)
    uv = np.einsum("...k,...kc->...c", b, geo.uvs[tri])
    out = []
    for k in geo.tex_index[0]:
        if k < 0:
            continue
        info = geo.tex_info[k]
        out.append(np.floor(uv[..., 0] * info[TEX_TILE_U] * info[TEX_WIDTH] - 0.5))
        out.append(np.floor(uv[..., 1] * info[TEX_TILE_V] * info[TEX_HEIGHT] - 0.5))
    return np.stack(out, axis=-1) if out else np.zeros(hits.prim.shape + (0,))


def _checks(scene, frame, rng):
    """The perturbations checked: six seen vertices' components, the eye's and the rotation's."""
    seen = np.unique(scene.geometry.faces[frame.hits.prim[frame.hits.prim >= 0]])
    cam = scene.camera
    out = []
    for i in rng.choice(seen, 6, replace=False):
        for c in range(3):
            out.append((("vertices", (i, c)), lambda h, i=i, c=c: _moved_vertex(scene, i, c, h)))
    for c in range(3):
        e = np.zeros(3)
        e[c] = 1.0
        out.append((("camera_eye", c), lambda h, e=e: scene.replace(camera=cam.replace(
            eye=tuple(np.array(cam.eye) + h * e), target=tuple(np.array(cam.target) + h * e)))))
        out.append((("camera_rotation", c), lambda h, e=e: scene.replace(camera=rotate_camera(cam, h * e))))
    return out


def refined(scene, shading):
    """The frame, its hit buffer's barycentrics replaced by the exact hits' (float32-rounded): Embree's
    float32 barycentrics are up to ~5e-6 off on this sphere, and a vertex colour's or a map's steep
    slope makes the derivative taken there differ from the oracle's at the exact hit by ~1e-5."""
    frame = rs.render(scene, shading)
    exact = exact_hits(scene, frame.hits)
    assert np.allclose(shade_reference(scene, scene.camera, exact, shading), frame.image, atol=1e-4)  # the oracle
    hit = frame.hits.prim >= 0
    assert np.max(np.abs(exact.u - frame.hits.u)[hit]) < 1e-5
    frame.hits.u[hit] = exact.u[hit]
    frame.hits.v[hit] = exact.v[hit]
    return frame


def _check_geometry(scene, shading, seed=11):
    frame = refined(scene, shading)
    checks = _checks(scene, frame, np.random.default_rng(3))
    moved = [(key, [(s, exact_hits(s, frame.hits)) for s in (make(STEP), make(-STEP))]) for key, make in checks]
    keep = frame.hits.prim >= 0
    for _, pair in moved:  # a pixel whose sample changes texel cells sits on a kink of the bilinear map
        keep &= np.all(_cells(*pair[0]) == _cells(*pair[1]), axis=-1)
    assert np.count_nonzero(frame.hits.prim >= 0) - np.count_nonzero(keep) < 20  # few pixels dropped
    weights = np.random.default_rng(seed).standard_normal(frame.image.shape) * keep[..., None]
    g = rs.grad(scene, weights, GEOMETRY, shading=shading, frame=frame)
    tops = {name: float(np.max(np.abs(g[name]))) for name in GEOMETRY}
    assert tops["vertices"] > 0.0
    for (name, index), pair in moved:
        loss = [float(np.sum(weights * shade_reference(s, s.camera, hits, shading))) for s, hits in pair]
        fd = (loss[0] - loss[1]) / (2 * STEP)
        got = g[name][index]
        scale = max(abs(fd), 1e-2 * tops[name], 1e-6)
        assert abs(got - fd) <= RTOL * scale, f"{name}{index}: kernel {got!r}, finite difference {fd!r}"
    return g


@pytest.mark.parametrize("shading,kind", [("phong", "maps"), ("phong", "vertex"), ("phong", "face"),
                                          ("gouraud", "maps"), ("gouraud", "vertex-plain"),
                                          ("gouraud", "vertex"), ("flat", "maps")])
def test_geometry_gradients_on_textured_scenes_match_central_differences(shading, kind):
    _check_geometry(_textured(kind), shading)


def _coloured_sphere(shift=(0.0, 0.0, 0.0)):
    """test_grad_edges' sphere with vertex colours and a kd map (bilinear)."""
    base = rs.shapes.icosphere(3, radius=1.2, center=tuple(shift))
    rgb = np.random.default_rng(4).uniform(0.2, 0.9, (base.vertices.shape[0], 3))
    mesh = rs.Mesh(base.vertices, base.faces, normals=base.normals, uvs=base.uvs, colors=rgb, color_mode="vertex")
    material = rs.Material(ka=0.2, kd=(0.7, 0.5, 0.3), ks=0.3, shininess=10.0, kd_map=_texture(3, "repeat", (6, 8)))
    return rs.Scene([rs.Model(mesh, material)], camera=edges_camera(),
                    lights=[rs.PointLight((2.0, 3.0, 4.0), intensity=20.0, attenuation="inverse_square")],
                    ambient=0.3, background=(0.1, 0.2, 0.3))


def test_silhouette_of_a_textured_sphere_matches_the_anti_aliased_image():
    """``edges=True`` on a coloured, kd-mapped sphere: its side rays are shaded with the frame's colours
    and maps (grad_edges shades them with the frame's kernels), the interior with the coefficients'
    motion; a translation against central differences of the 16x16-ray image (test_grad_edges'
    oracle and tolerance)."""
    weights = smooth_weights()
    g = rs.grad(_coloured_sphere(), weights, ("vertices",), shading="phong", edges=True, edge_density=16.0,
                samples=16)
    total = g["vertices"].sum(axis=0)
    top = float(np.max(np.abs(total)))
    assert top > 0.0
    for c in range(3):
        e = np.eye(3)[c]
        up = np.sum(weights * anti_aliased(_coloured_sphere(EDGE_STEP * e), "phong"))
        down = np.sum(weights * anti_aliased(_coloured_sphere(-EDGE_STEP * e), "phong"))
        fd = float(up - down) / (2.0 * EDGE_STEP)
        assert abs(total[c] - fd) <= EDGE_RTOL * top, f"shift[{c}]: edge sampling {total[c]!r}, finite difference {fd!r}"


def test_textured_geometry_gradients_are_bit_identical_across_thread_counts():
    import numba

    scene = _textured("vertex")
    scene = scene.replace(models=scene.models + (dataclasses.replace(
        scene.models[0], pose=np.array([[1, 0, 0, 1.3], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1.0]])),))
    shading = ["phong", "gouraud"]
    frame = rs.render(scene, shading)
    weights = np.random.default_rng(2).standard_normal(frame.image.shape)
    runs = []
    before = numba.get_num_threads()
    try:
        for threads in (1, 2, 2):
            numba.set_num_threads(min(threads, numba.config.NUMBA_NUM_THREADS))
            runs.append(rs.grad(scene, weights, GEOMETRY, shading=shading, frame=frame))
    finally:
        numba.set_num_threads(before)
    for run in runs[1:]:
        for name, value in runs[0].items():
            assert value.tobytes() == run[name].tobytes(), name
    assert np.any(runs[0]["vertices"] != 0.0)
