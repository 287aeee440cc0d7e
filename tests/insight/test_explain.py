"""frame.explain(x, y): the model at one pixel with its numbers, equal to the kernels' pixel."""

from __future__ import annotations

import re

import numpy as np
import pytest

import raycast_shade as rs
from raycast_shade.study.reference import illuminate_reference
from tests.shading.test_terms import MODES, SCENES, lamp_scene, render_quiet

# explain() works in float64 from the same float32 hit buffer; the kernels store float32:
# the totals agree to the image's rounding (measured: 0.50 ulp for local shading, 1.1 ulp on mirrors).
RTOL = float(np.finfo(np.float32).eps)


@pytest.fixture(scope="module")
def frames():
    out = {}
    for name, make in SCENES.items():
        scene = make(40, 30)
        for mode in MODES:
            out[name, mode] = render_quiet(scene, mode, terms="per_light")
    scene = lamp_scene(40, 30)
    for att in ("none", "heuristic"):
        lights = (rs.PointLight((2.0, 3.0, 2.0), intensity=3.0, attenuation=att, k=0.7, shadows=True),)
        out["lamp_" + att, "phong"] = render_quiet(scene.replace(lights=lights), "phong", terms="per_light")
    ortho = scene.replace(camera=rs.Camera(eye=(0.0, 1.2, 4.0), target=(0.0, -0.3, 0.0), width=40, height=30,
                                           projection="orthographic", ortho_height=4.0))
    out["lamp_ortho", "gouraud"] = render_quiet(ortho, "gouraud", terms="per_light")
    out["lamp_screen", "gouraud"] = render_quiet(scene, "gouraud", interpolation="screen", terms="per_light")
    out["lamp_raster", "phong"] = render_quiet(scene, "phong", backend="raster", terms="per_light")
    return out


def _pixels(frame, n, seed):
    ys, xs = np.nonzero(frame.mask)
    pick = np.random.default_rng(seed).choice(len(xs), size=min(n, len(xs)), replace=False)
    return [(int(xs[i]), int(ys[i])) for i in pick]


def _close(a, b, rtol=RTOL):
    a, b = np.asarray(a, np.float64), np.asarray(b, np.float64)
    return np.all(np.abs(a - b) <= rtol * np.abs(b) + 1e-30)


def test_explain_total_equals_the_pixel_for_random_pixels(frames):
    bad = []
    for (name, mode), frame in frames.items():
        for k, (x, y) in enumerate(_pixels(frame, 24, seed=len(name) + len(mode))):
            e = frame.explain(x, y)
            # A mirror pixel is summed in float32 bounce by bounce: one rounding more per bounce.
            if not _close(e.total, frame.image[y, x], RTOL * (1 + len(e.bounces))):
                bad.append((name, mode, x, y, e.total.tolist(), frame.image[y, x].tolist()))
            assert e.method == mode and np.array_equal(e.image, frame.image[y, x])
    assert not bad, bad[:5]


def test_explain_terms_match_the_term_images(frames):
    # Two routes to the same numbers: the kernels over variant scenes, and explain's float64 walk.
    for (name, mode), frame in frames.items():
        t = frame.terms
        for x, y in _pixels(frame, 8, seed=3):
            e = frame.explain(x, y)
            for term in ("ambient", "diffuse", "specular"):
                assert _close(getattr(e, term), t[term][y, x]) or np.allclose(getattr(e, term), t[term][y, x],
                                                                               rtol=RTOL, atol=1e-7)
            for i in range(len(frame.scene.lights)):
                d = sum(w * s.lights[i].diffuse for w, s in zip(e.weights, e.shades))
                np.testing.assert_allclose(d, t["diffuse_per_light"][i, y, x], rtol=2 * RTOL, atol=1e-7)


def test_shadow_rays_agree_with_the_mask(frames):
    frame = frames["lamp", "phong"]
    mask = frame.terms["shadow"][0]
    blocked = list(zip(*np.nonzero(frame.mask & (mask == 0))))
    lit = list(zip(*np.nonzero(frame.mask & (mask == 1))))
    assert len(blocked) > 5
    for y, x in blocked[:10]:
        e = frame.explain(int(x), int(y))
        assert e.shades[0].lights[0].shadow == "blocked"
        assert np.all(e.shades[0].lights[0].diffuse == 0)
        assert "BLOCKED" in str(e)
    for y, x in lit[:: max(1, len(lit) // 10)]:
        assert frame.explain(int(x), int(y)).shades[0].lights[0].shadow in ("lit", "not traced")


def test_gouraud_has_three_vertex_shades_and_convex_weights(frames):
    frame = frames["lamp", "gouraud"]
    x, y = _pixels(frame, 1, seed=5)[0]
    e = frame.explain(x, y)
    assert len(e.shades) == 3 and abs(e.weights.sum() - 1.0) < 1e-12 and np.all(e.weights >= 0)
    assert [s.where for s in e.shades] == [f"vertex {i}" for i in e.vertex_ids]
    np.testing.assert_allclose(e.local, sum(w * s.total for w, s in zip(e.weights, e.shades)), rtol=1e-14)


def test_flat_is_evaluated_at_the_face_centre_with_the_face_normal(frames):
    frame = frames["lamp", "flat"]
    geo = frame.scene.geometry
    x, y = _pixels(frame, 1, seed=6)[0]
    e = frame.explain(x, y)
    s = e.shades[0]
    f = geo.face_offsets[e.model] + e.triangle
    np.testing.assert_allclose(s.p, geo.vertices[geo.faces[f]].mean(axis=0) + geo.origin, atol=1e-12)
    np.testing.assert_allclose(np.abs(s.n), np.abs(geo.face_normals[f]), atol=1e-12)


def test_explain_agrees_with_the_numpy_reference_without_shadows():
    scene = lamp_scene(40, 30)
    scene = scene.replace(lights=tuple(rs.PointLight(lt.position, intensity=lt.intensity, attenuation=lt.attenuation)
                                       if isinstance(lt, rs.PointLight) else lt for lt in scene.lights))
    frame = rs.render(scene, "phong")
    geo = scene.geometry
    from raycast_shade.study.reference import _lights, _materials

    for x, y in _pixels(frame, 10, seed=7):
        s = frame.explain(x, y).shades[0]
        ref = illuminate_reference((s.p - geo.origin)[None], s.n[None], s.v[None], np.array([s.model]),
                                   _materials(scene), _lights(scene, geo.origin), np.asarray(scene.ambient), 1e-6 * geo.scale)
        np.testing.assert_allclose(s.total, ref[0], rtol=1e-12)


def test_mirror_pixels_have_their_bounces(frames):
    frame = frames["mirror", "phong"]
    floor = np.nonzero(frame.hits.geom == 1)
    x, y = int(floor[1][0]), int(floor[0][0])
    e = frame.explain(x, y)
    assert e.rho == 0.5 and len(e.bounces) >= 1 and e.bounces[0].weight == 0.5
    np.testing.assert_allclose(e.total, 0.5 * e.local + e.reflected, rtol=1e-14)
    assert "mirror: I = (1 - rho) I_local" in str(e)


def test_str_prints_the_formula_with_the_numbers(frames):
    frame = frames["lamp", "phong"]
    x, y = _pixels(frame, 1, seed=8)[0]
    e = frame.explain(x, y)
    text = str(e)
    assert text.startswith(f"pixel ({x}, {y}): Phong shading of model {e.model}")
    assert "I = Ia ka + sum_i att_i Ii (kd (n.s_i) + Ks (r_i.v)^t)" in text
    t = e.shades[0].lights[0]
    assert f"d = {t.d:.4g}" in text and f"att = {t.att:.4g}" in text and f"n.s = {t.ndots:.4g}" in text
    assert "inverse square" in text
    from raycast_shade.insight.explain_text import fmt

    assert f"total I = {fmt(e.total)}" in text and fmt(frame.image[y, x]) in text
    assert max(len(line) for line in text.splitlines()) <= 110
    blinn = frames["blinn", "gouraud"]
    ys, xs = np.nonzero(blinn.hits.geom == 0)  # the Blinn sphere
    text = str(blinn.explain(int(xs[len(xs) // 2]), int(ys[len(ys) // 2])))
    assert "Gouraud shading" in text and "(n.h_i)^t" in text and "vertex" in text and "heuristic" in text


def test_background_and_bad_pixels():
    frame = rs.render(lamp_scene(16, 12).replace(models=(rs.Model(rs.shapes.icosphere(1, radius=0.3)),)), "phong")
    ys, xs = np.nonzero(~frame.mask)
    e = rs.explain(frame, int(xs[0]), int(ys[0]))
    assert e.method is None and np.array_equal(e.total, [0.05, 0.1, 0.2]) and "background" in str(e)
    with pytest.raises(ValueError, match="x"):
        frame.explain(16, 0)
    with pytest.raises(ValueError, match="y"):
        frame.explain(0, -1)
    with pytest.raises(TypeError, match="x"):
        frame.explain(1.5, 0)
    with pytest.raises(TypeError, match="frame"):
        rs.explain(frame.image, 0, 0)
    import dataclasses

    with pytest.raises(ValueError, match="raycast_shade.explain"):
        dataclasses.replace(frame, explainer=None).explain(0, 0)


def test_vectors_print_as_vectors_even_with_equal_components():
    """Issue 46: s = (0.5774, 0.5774, 0.5774) printed as 's = 0.5774' read as a scalar. Geometric vectors
    always print three components; an RGB value with equal channels (a grey kd, Ii) stays one number."""
    from raycast_shade.insight.explain_text import fmt, vec

    assert vec(np.full(3, 1 / np.sqrt(3))) == "(0.5774, 0.5774, 0.5774)"
    assert fmt(np.full(3, 0.8)) == "0.8" and fmt((0.8, 0.3, 0.2)) == "(0.8, 0.3, 0.2)"
    scene = rs.Scene([rs.Model(rs.shapes.icosphere(2), rs.Material(kd=0.7, ks=0.4, shininess=20))],
                     lights=[rs.DirectionalLight((-1.0, -1.0, -1.0))],
                     camera=rs.Camera(eye=(0.0, 0.0, 3.2), width=24, height=18))
    frame = rs.render(scene, "phong")
    ys, xs = np.nonzero(frame.mask)
    text = str(frame.explain(int(xs[len(xs) // 2]), int(ys[len(ys) // 2])))
    assert "light 0, directional: s = (0.5774, 0.5774, 0.5774), att = 1, Ii = 1" in text, text
    for name in ("p", "n", "v"):
        assert re.search(rf"\b{name} = \(-?[0-9.e-]+, -?[0-9.e-]+, -?[0-9.e-]+\)", text), name
    assert "kd = 0.7" in text  # a grey coefficient stays one number
