"""The gradient kernels against an autograd twin (issue 43, item 4): the lecture's interior shading
written again in plain ``jax.numpy`` (float64), differentiated by ``jax.vjp``, against ``rs.grad``.

The twin mirrors ``study.reference.shade_reference`` (itself checked against ``rs.render`` in
tests/shading/test_grad_fd.py) line for line, but only from the frame's hit buffer on: which
triangle each pixel sees and where (``gather_hits``), the view vectors and the geometric normals
turned to the viewer (``view_vectors``, ``facing``) are constants; the materials, the ambient, the
lights (positions, unit directions, radiance or intensity, the heuristic ``k``) and the packed
vertex normals are the twin's inputs. Phong per pixel with the renormalised interpolated normal,
Gouraud per corner, flat per face at its centre; Phong and Blinn lobes; point, spot and
directional lights; the three attenuation laws. The loss is ``sum(W * I)`` over the frame's hit
pixels with a random ``W``. Every family agrees to a relative 1e-12 of its largest component (measured
2026-12-05: at most 9.1e-15, the spot scene's flat light position; the kernels and the twin are both
float64 over the same hits, so only the order of the sums differs).
"""

from __future__ import annotations

import numpy as np
import pytest

import raycast_shade as rs
from raycast_shade.scene.lights import DirectionalLight, SpotLight
from raycast_shade.study.reference import facing, gather_hits, shade_reference, view_vectors

jax = pytest.importorskip("jax", reason="the [jax] extra (CI installs it with [test])")
jax.config.update("jax_enable_x64", True)
jnp = jax.numpy

H, W = 36, 48
RTOL = 1e-12
CANCEL = 1e-6  # study.reference: |interpolated normal| below this falls back to the geometric normal


def _scene(specular, lights):
    material = rs.Material(kd=(0.6, 0.4, 0.3), ka=(0.5, 0.6, 0.7), ks=(0.5, 0.4, 0.6), shininess=20.0,
                           specular=specular)
    return rs.Scene([rs.Model(rs.shapes.icosphere(2), material)], lights=lights,
                    camera=rs.Camera(eye=(0.0, 0.0, 4.0), width=W, height=H), ambient=(0.1, 0.12, 0.08))


def _phong_scene():
    return _scene("phong", [rs.PointLight((2.0, 3.0, 4.0), intensity=20.0, attenuation="inverse_square"),
                            rs.DirectionalLight((-1.0, -0.5, -1.0), intensity=0.5, color=(1.0, 0.8, 0.6)),
                            rs.PointLight((-2.5, -1.0, 3.0), intensity=0.3, color=(0.7, 0.9, 1.0))])


def _blinn_scene():
    """Blinn's lobe; a spot light whose cone edge crosses the sphere (Warn's smooth step) and a point
    light, both with the heuristic law."""
    return _scene("blinn", [rs.SpotLight((0.5, 2.5, 3.0), direction=(-0.2, -0.8, -1.0), intensity=6.0, exponent=3.0,
                                         inner_angle=8.0, outer_angle=18.0, attenuation="heuristic", k=0.7),
                            rs.PointLight((-3.0, 1.0, 2.0), intensity=4.0, attenuation="heuristic", k=1.5,
                                          color=(0.9, 1.0, 0.7))])


# -- the twin -------------------------------------------------------------------------------------------
def _unit(a):
    length = jnp.linalg.norm(a, axis=-1)
    safe = jnp.where(length > 0, length, 1.0)
    return a / safe[..., None], length


def _dot(a, b):
    return jnp.sum(a * b, axis=-1)


def _warn(cone, s):
    axis, ci, co, n = cone
    c = jnp.minimum(-(s @ axis), 1.0)
    t = jnp.clip((c - co) / (ci - co), 0.0, 1.0) if ci > co else jnp.ones_like(c)
    cpos = jnp.where(c > 0.0, c, 1.0)
    return jnp.where(c > co, jnp.where(c > 0.0, cpos ** n, 0.0) * t * t * (3.0 - 2.0 * t), 0.0)


def illuminate(P, k, p, n, v, model):
    """``study.reference.illuminate_reference`` in jax.numpy: (N, 3) at points ``p`` with unit normals
    ``n`` and view vectors ``v``; ``P`` the parameters, ``k`` the constants."""
    ka, kd, ks, shin = P["ka"][model], P["kd"][model], P["ks"][model], P["shininess"][model]
    blinn, has_spec = k["blinn"][model], k["has_spec"][model]
    radiance = P["light_radiance"] if "light_radiance" in P else P["light_intensity"][:, None] * k["colors"]
    out = P["ambient"][None, :] * ka
    for j, (directional, law, cone) in enumerate(k["lights"]):
        if directional:
            s = jnp.broadcast_to(-_unit(P["light_direction"][j])[0], p.shape)
            att, present = jnp.ones(len(p)), jnp.ones(len(p), bool)
        else:
            s, d = _unit(P["light_position"][j] - k["origin"] - p)
            present = d > 0.0
            if law == "inverse_square":
                att = 1.0 / jnp.maximum(d, k["dmin"]) ** 2
            elif law == "heuristic":
                att = 1.0 / (d + P["light_k"][j])
            else:
                att = jnp.ones(len(p))
            if cone is not None:
                att = att * _warn(cone, s)
        ndots = _dot(n, s)
        lit = present & (ndots > 0.0)
        ndots = jnp.clip(ndots, 0.0, 1.0)
        h, hl = _unit(s + v)
        c_blinn = jnp.where(hl > 0.0, _dot(n, h), 0.0)
        c_phong = _dot(2.0 * ndots[:, None] * n - s, v)
        c = jnp.clip(jnp.where(blinn, c_blinn, c_phong), 0.0, 1.0)
        on = (c > 0.0) & has_spec
        spec = jnp.where(on, jnp.where(on, c, 1.0) ** shin, 0.0)  # no ln(0) in the untaken branch's derivative
        term = att[:, None] * radiance[j][None, :] * (kd * ndots[:, None] + ks * spec[:, None])
        out = out + jnp.where(lit[:, None], term, 0.0)
    return out


def constants(scene, frame):
    """Everything the twin holds fixed: the hit buffer's pixels and their geometry, the lights' kinds."""
    geo = scene.geometry
    cam = scene.camera
    mask, face, tri, bary, p = gather_hits(geo, frame.hits)
    fwd = (cam.target - cam.eye) / np.linalg.norm(cam.target - cam.eye)
    eye, ortho = cam.eye - geo.origin, cam.orthographic
    v = view_vectors(eye, fwd, ortho, p)
    g, sgn = facing(geo.face_normals[face], v)
    mats = [m.material for m in scene.models]
    lights = []
    for light in scene.lights:
        directional = isinstance(light, DirectionalLight)
        cone = (np.asarray(light.direction, float), light.cos_inner, light.cos_outer, light.exponent) \
            if isinstance(light, SpotLight) else None
        lights.append((directional, "none" if directional else light.attenuation, cone))
    faces, inverse = np.unique(face, return_inverse=True)
    centre = geo.vertices[geo.faces[faces]].sum(axis=1) / 3.0
    vc = view_vectors(eye, fwd, ortho, centre)
    gc, _ = facing(geo.face_normals[faces], vc)
    return dict(mask=mask, face=face, tri=tri, bary=bary, p=p, v=v, g=g, sgn=sgn, model=geo.face_model[face],
                blinn=np.array([m.specular == "blinn" for m in mats]),
                has_spec=np.array([np.any(np.asarray(m.ks) > 0) for m in mats]),
                colors=np.array([np.broadcast_to(li.color, 3) for li in scene.lights], float),
                lights=lights, origin=geo.origin, dmin=1e-6 * geo.scale, vertices=geo.vertices,
                missing=~np.any(geo.normals != 0.0, axis=1), faces=faces, inverse=inverse.ravel(), centre=centre,
                vc=vc, gc=gc, face_model=geo.face_model[faces], eye=eye, fwd=fwd, ortho=ortho)


def twin(P, k, shading):
    """The hit pixels' colours (N, 3), in the row-major order of ``k["mask"]``."""
    if shading == "flat":
        return illuminate(P, k, k["centre"], k["gc"], k["vc"], k["face_model"])[k["inverse"]]
    g, sgn, tri, bary = k["g"], k["sgn"], k["tri"], k["bary"]
    if shading == "phong":
        n, length = _unit(jnp.einsum("nk,nkc->nc", bary, P["normals"][tri]))
        n = n * sgn[:, None]
        c = _dot(n, g)
        n = jnp.where((c < 0.0)[:, None], n - 2.0 * c[:, None] * g, n)
        n = jnp.where((length >= CANCEL)[:, None], n, g)
        return illuminate(P, k, k["p"], n, k["v"], k["model"])
    acc = 0.0
    for c in range(3):  # Gouraud: each corner shaded with its normal, turned as the pixel sees the face
        idx = tri[:, c]
        q = k["vertices"][idx]
        n = jnp.where(k["missing"][idx][:, None], g, sgn[:, None] * P["normals"][idx])
        cg = jnp.minimum(_dot(n, g), 0.0)
        n = n - 2.0 * cg[:, None] * g
        vq = view_vectors(k["eye"], k["fwd"], k["ortho"], q)
        acc = acc + bary[:, c, None] * illuminate(P, k, q, n, vq, k["model"])
    return acc


def start(scene, names):
    """The twin's inputs: the scene's values of ``names``, float64."""
    values = {}
    mats = [m.material for m in scene.models]
    for name in ("ka", "kd", "ks"):
        values[name] = np.array([np.broadcast_to(getattr(m, name), 3) for m in mats], float)
    values["shininess"] = np.array([m.shininess for m in mats], float)
    values["ambient"] = np.array(np.broadcast_to(scene.ambient, 3), float)
    lights = scene.lights
    values["light_position"] = np.array([np.zeros(3) if isinstance(li, DirectionalLight) else li.position
                                         for li in lights], float)
    values["light_direction"] = np.array([li.direction if isinstance(li, DirectionalLight) else np.zeros(3)
                                          for li in lights], float)
    values["light_k"] = np.array([0.0 if isinstance(li, DirectionalLight) else li.k for li in lights], float)
    values["normals"] = scene.geometry.normals.copy()
    if "light_intensity" in names:
        values["light_intensity"] = np.array([li.intensity for li in lights], float)
    else:
        values["light_radiance"] = np.array([li.intensity * np.broadcast_to(li.color, 3) for li in lights], float)
    return {n: jnp.asarray(v) for n, v in values.items()}


SCENES = {"phong lobe, inverse-square + directional + none": _phong_scene,
          "blinn lobe, spot + heuristic": _blinn_scene}
FAMILIES = (("ka", "kd", "ks", "shininess", "ambient", "light_position", "light_direction", "light_radiance",
             "light_k", "normals"), ("light_intensity",))


def _twin_vjp(scene, frame, shading, names, weights):
    k = constants(scene, frame)
    P = start(scene, names)
    image, back = jax.vjp(lambda q: twin(q, k, shading), P)
    (g,) = back(jnp.asarray(weights[k["mask"]]))
    return np.asarray(image), {n: np.asarray(g[n]) for n in names}


@pytest.mark.parametrize("shading", ["phong", "gouraud", "flat"])
@pytest.mark.parametrize("make", list(SCENES.values()), ids=list(SCENES))
@pytest.mark.parametrize("names", FAMILIES, ids=["all families", "light_intensity"])
def test_twin_vjp_is_rs_grad(make, shading, names):
    scene = make()
    frame = rs.render(scene, shading)
    weights = np.random.default_rng(43).normal(size=(H, W, 3))
    image, want = _twin_vjp(scene, frame, shading, names, weights)
    # The twin's forward pass is the reference shader's image (and so rs.render's, tested elsewhere).
    ref = shade_reference(scene, scene.camera, frame.hits, shading)[frame.hits.prim >= 0]
    np.testing.assert_allclose(image, ref, rtol=0, atol=1e-12)
    np.testing.assert_allclose(image, frame.image[frame.hits.prim >= 0], rtol=1e-5, atol=1e-6)
    got = rs.grad(scene, weights, names, shading=shading, frame=frame)
    for name in names:
        w = want[name]
        if name == "light_position":  # rs.grad's rows of directional lights are 0 by definition
            w = np.where(np.array([isinstance(li, DirectionalLight) for li in scene.lights])[:, None], 0.0, w)
        if name == "light_k":  # and its k of lights without the heuristic law
            w = np.where(np.array([getattr(li, "attenuation", "") == "heuristic" for li in scene.lights]), w, 0.0)
        scale = float(np.max(np.abs(w)))
        if name == "normals" and shading == "flat":
            assert scale == 0.0, "flat shading uses the face normal"
        if scale == 0.0:  # no light of the kind (light_direction, light_k), or flat's normals: 0 both
            assert not np.any(got[name]), name
            continue
        err = float(np.max(np.abs(got[name] - w))) / scale
        assert err <= RTOL, (name, err)

