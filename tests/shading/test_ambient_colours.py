"""The ambient term takes the surface's colour where a file gives no ambient colour (issue 22 item 2).

A quad at z = 0 with vertex (PLY) or face (OFF) colours, seen from +z and lit only from behind:
every pixel is ``Ia ka`` alone, so with ``ka_colors`` it is ``Ia`` times the colour under it
(interpolated from the vertices: the barycentric buffer gives the point), and with an explicit
``Material(ka=...)`` it is ``Ia ka``, uncoloured. The NumPy twin must agree in every mode.
"""

from __future__ import annotations

import numpy as np
import pytest

import raycast_shade as rs
from raycast_shade.scene.texture import srgb_to_linear
from raycast_shade.study.reference import shade_reference

from tests.conftest import down_camera

IA = np.array([0.5, 0.4, 0.25])
BYTES = np.array([[255, 0, 0], [0, 255, 0], [0, 0, 255], [255, 255, 0]])
QUAD = np.array([[-1.0, -1.0, 0.0], [1.0, -1.0, 0.0], [1.0, 1.0, 0.0], [-1.0, 1.0, 0.0]])


def _ply(path):
    rows = [f"{x} {y} {z} {r} {g} {b}" for (x, y, z), (r, g, b) in zip(QUAD, BYTES)]
    path.write_text("ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\n"
                    "property float z\nproperty uchar red\nproperty uchar green\nproperty uchar blue\n"
                    "element face 2\nproperty list uchar int vertex_indices\nend_header\n"
                    + "\n".join(rows) + "\n3 0 1 2\n3 0 2 3\n")


def _off(path):
    path.write_text("OFF\n4 2 0\n" + "\n".join(" ".join(map(str, v)) for v in QUAD)
                    + "\n3 0 1 2 255 64 0\n3 0 2 3 0 128 255\n")


def _back_lit(models):
    """The models seen from +z, with one light below the quad (it lights only the far side)."""
    cam = down_camera(eye=(0.0, 0.0, 4.0), width=41, height=41)
    light = rs.DirectionalLight((0.0, 0.0, 1.0), intensity=3.0)  # travelling up (+z): it reaches the far side only
    return rs.Scene(models, lights=[light], camera=cam, ambient=tuple(IA))


def _colour_under(frame, model, centre=False):
    """(N, 3) the mesh colour under each seen pixel, interpolated at the hit's barycentrics
    (``centre``: at its face's centre, where flat shading evaluates the equation)."""
    hits = frame.hits
    seen = hits.prim >= 0
    mesh = model.mesh.prepared
    if model.mesh.color_mode == "face":
        return mesh.colors[hits.prim[seen]]
    tri = mesh.faces[hits.prim[seen]]
    u, v = hits.u[seen].astype(np.float64), hits.v[seen].astype(np.float64)
    if centre:
        u, v = np.full_like(u, 1.0 / 3.0), np.full_like(v, 1.0 / 3.0)
    bary = np.stack([1.0 - u - v, u, v], axis=1)
    return np.einsum("nk,nkc->nc", bary, mesh.colors[tri])


@pytest.mark.parametrize("writer", [_ply, _off], ids=["ply_vertex_colours", "off_face_colours"])
def test_back_lit_coloured_file_shows_its_colours_in_the_ambient_term(tmp_path, writer):
    path = tmp_path / ("q.ply" if writer is _ply else "q.off")
    writer(path)
    (model,) = rs.load_models(path)
    assert model.mesh.colors is not None
    assert model.material.ka_colors and model.material.ka.tolist() == [1.0] * 3
    scene = _back_lit([model])
    for shading in rs.SHADINGS:
        frame = rs.render(scene, shading)
        seen = frame.hits.prim >= 0
        assert seen.sum() > 100
        got = frame.image[seen].astype(np.float64)
        expected = IA * _colour_under(frame, model, centre=shading == "flat")
        # Gouraud interpolates vertex shades, which is the same linear interpolation of the colours.
        np.testing.assert_allclose(got, expected, rtol=2e-6, atol=1e-7)
        assert np.ptp(got, axis=0).max() > 0.1 and np.ptp(got, axis=1).max() > 0.1  # coloured, not one grey
        np.testing.assert_allclose(got, shade_reference(scene, scene.camera, frame.hits, shading)[seen],
                                   rtol=2e-6, atol=1e-7)


def test_the_ply_colours_are_the_files_decoded_from_srgb(tmp_path):
    _ply(tmp_path / "q.ply")
    (model,) = rs.load_models(tmp_path / "q.ply")
    np.testing.assert_allclose(model.mesh.colors, srgb_to_linear(BYTES / 255.0), atol=1e-6)


def test_an_explicit_ka_stays_exact_on_a_coloured_mesh():
    colours = srgb_to_linear(BYTES / 255.0)
    mesh = rs.Mesh(QUAD, np.array([[0, 1, 2], [0, 2, 3]]), colors=colours, color_mode="vertex")
    scene = _back_lit([rs.Model(mesh, rs.Material(ka=0.3))])
    for shading in rs.SHADINGS:
        frame = rs.render(scene, shading)
        seen = frame.hits.prim >= 0
        np.testing.assert_allclose(frame.image[seen], np.broadcast_to(0.3 * IA, (seen.sum(), 3)), rtol=1e-6)
    # ka_colors scales the given ka by the colour: ka = 0.3 of the surface's colour.
    model = rs.Model(mesh, rs.Material(ka=0.3, ka_colors=True))
    scene = _back_lit([model])
    frame = rs.render(scene, "phong")
    seen = frame.hits.prim >= 0
    np.testing.assert_allclose(frame.image[seen], 0.3 * IA * _colour_under(frame, model), rtol=2e-6, atol=1e-7)


def test_ka_colors_is_validated_and_packed():
    with pytest.raises(TypeError, match="m.ka_colors: expected True or False"):
        rs.Material(name="m", ka_colors="yes")
    from raycast_shade.common.layout import MAT_KA_COLORS

    assert rs.Material(ka_colors=True).packed()[MAT_KA_COLORS] == 1.0
    assert rs.Material().packed()[MAT_KA_COLORS] == 0.0


def test_a_kd_override_replaces_the_colours_and_carries_ka_along():
    from raycast_shade.scene.material import overridden

    base = rs.Material(ka=1.0, ka_colors=True)
    out = rs.Material(**overridden(base, {"kd": 0.5}))
    assert out.ka.tolist() == [0.5] * 3 and not out.ka_colors
    out = rs.Material(**overridden(base, {"ka": 0.2}))
    assert out.ka.tolist() == [0.2] * 3 and not out.ka_colors


def test_a_gltf_with_color_0_takes_its_colours_as_ka_too(tmp_path):
    """COLOR_0 without a material: kd is the colours, and ka x colour is the colour as well."""
    import trimesh

    box = trimesh.creation.box()
    rgba = np.random.default_rng(2).integers(0, 256, (8, 4)).astype(np.uint8)
    rgba[:, 3] = 255
    box.visual = trimesh.visual.ColorVisuals(box, vertex_colors=rgba)
    box.export(tmp_path / "c.glb")
    (model,) = rs.load_models(tmp_path / "c.glb")
    assert model.mesh.color_mode == "vertex"
    assert model.material.ka_colors and model.material.ka.tolist() == [1.0] * 3
