"""The gradient kernels' walk (shading/grad_walk.py): which points a kernel differentiates, and what
it reads there, against NumPy's reading of the same hit buffer."""

from __future__ import annotations

import numpy as np

import raycast_shade as rs
from raycast_shade.common.layout import METHOD_GOURAUD, METHOD_PHONG
from raycast_shade.shading.grad_walk import chunk_items, chunks, corner_gather, face_grad, pixel_grad, vertex_grad
from raycast_shade.shading.inputs import prepare
from raycast_shade.shading.jit import CHUNK

from .test_grad_fd import _scene


def _two_models():
    """Two spheres, Phong and Gouraud, and a dL/dI that is zero on a band of rows."""
    scene = _scene()
    pose = np.array([[1, 0, 0, 1.3], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1.0]])
    scene = scene.replace(models=scene.models + (rs.Model(scene.models[0].mesh, scene.models[0].material, pose=pose),))
    frame = rs.render(scene, ["phong", "gouraud"])
    gimg = np.random.default_rng(2).standard_normal(frame.image.shape)
    gimg[10:14] = 0.0
    return scene, frame, gimg


def test_pixel_grad_takes_the_hits_of_its_method_with_a_nonzero_gradient():
    scene, frame, gimg = _two_models()
    face_off = prepare(scene, scene.camera).face_off
    hits = (frame.hits.prim, frame.hits.geom, frame.hits.u, frame.hits.v)
    modes = np.array([METHOD_PHONG, METHOD_GOURAUD], np.int8)
    prim, geom = frame.hits.prim, frame.hits.geom
    for method in (METHOD_PHONG, METHOD_GOURAUD):
        want = (prim >= 0) & (modes[np.maximum(geom, 0)] == method) & np.any(gimg != 0.0, axis=2)
        assert want.sum() > 50 and (want != (prim >= 0)).any()
        for y in range(prim.shape[0]):
            for x in range(prim.shape[1]):
                shaded, at, gI = pixel_grad(hits, face_off, modes, method, gimg, y, x)
                assert shaded == want[y, x], (method, y, x)
                if shaded:
                    assert at == (face_off[geom[y, x]] + prim[y, x], geom[y, x], float(frame.hits.u[y, x]),
                                  float(frame.hits.v[y, x]))
                    assert gI == tuple(gimg[y, x])


def test_faces_and_vertex_sides_without_a_gradient_are_skipped_and_the_others_lit_as_the_forward_pass():
    scene, frame, _ = _two_models()
    k = prepare(scene, scene.camera)
    G, cam = k.geometry, k.cam
    nf, nv = G.faces.shape[0], G.verts.shape[0]
    gface = np.zeros((nf, 3))
    gface[::3, 1] = 0.5
    f = 3
    shaded, hp, gI = face_grad(G, cam, gface, f)
    assert shaded and gI == (0.0, 0.5, 0.0)
    centre = G.verts[G.faces[f]].mean(axis=0)
    np.testing.assert_allclose(hp.p, centre, rtol=1e-12, atol=1e-12)
    assert abs(abs(np.dot(hp.n, G.face_normals[f])) - 1.0) < 1e-12 and hp.n == hp.g
    assert not face_grad(G, cam, gface, 4)[0]
    gvert = np.zeros((nv, 2, 3))
    gvert[5, 1, 2] = -1.0
    shaded, hp, gI = vertex_grad(G, cam, gvert, 5, 1)
    assert shaded and gI == (0.0, 0.0, -1.0) and hp.n == tuple(-G.normals[5])
    assert not vertex_grad(G, cam, gvert, 5, 0)[0]


def test_a_stored_corner_takes_its_share_and_the_chunks_cover_every_item_once():
    scene, frame, gimg = _two_models()
    k = prepare(scene, scene.camera)
    G, cam = k.geometry, k.cam
    gvert = np.zeros((G.verts.shape[0], 2, 3))
    i = int(G.faces[0, 0])
    gn = tuple(G.normals[i])  # the vertex normal on the face's side: the corner's shade is stored
    spot, hp, gI = corner_gather(G, cam, gimg, 3, 4, i, 0.25, 0, gn, gvert)
    assert not spot and hp.n == gn
    assert gI == tuple(0.25 * gimg[3, 4]) and np.array_equal(gvert[i, 0], 0.25 * gimg[3, 4])
    assert np.count_nonzero(gvert) == np.count_nonzero(gimg[3, 4])
    spot, hp, _ = corner_gather(G, cam, gimg, 3, 4, i, 0.25, 1, gn, gvert)  # from the back: reflected, on the spot
    assert spot and np.count_nonzero(gvert[i, 1]) == 0
    n = 3 * CHUNK + 17
    seen = [j for p in range(5) for ch in range(*chunks(n, (p, 5))) for j in range(*chunk_items(n, ch))]
    assert seen == list(range(n))
