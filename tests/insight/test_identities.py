"""The teaching identities on random scenes: ``frame.explain(x, y).total`` equals the pixel, and the
``terms=True`` images add up to the image, whatever the material's colour comes from.

Hypothesis draws each scene from every source a pixel's colour can have: colour maps on ka, kd,
ks and ke and an occlusion map (wrapped or clamped, bilinear or mip-mapped, tiled), emission, vertex and face colours
(with the ambient term following them or not), a Blinn bump map, a tangent-space normal map,
point, directional and spot lights (a narrow cone, so some of the scene lies outside it), shadows,
a mirror floor; and renders it flat, Gouraud or Phong, with perspective or screen-space
interpolation, by ray casting or rasterization. Images are small (24 x 18) and the examples
bounded (40 scenes per method and property: 240 renders with terms, up to 9 pixels explained
on each of 120); ``derandomize=True`` makes every run draw the same scenes.
``--hypothesis-show-statistics`` lists how often each feature was drawn.

"Equal" means equal to float32 rounding. The kernels evaluate in float64 and store float32; explain
and the terms re-derive the pixel from the same float32 hit buffer in float64. Every term is
non-negative, so no cancellation amplifies rounding: the difference is a few float32 half-ulps of
the pixel, one for the stored image, one per stored term (``TERMS_RTOL``) or per mirror bounce
summed in float32 (``EXPLAIN_RTOL``). ``ATOL`` covers pixels that are 0 to within float64 noise.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from hypothesis import HealthCheck, Phase, event, given, settings
from hypothesis import strategies as st

import raycast_shade as rs
from raycast_shade.shading.terms import compose_terms

EPS32 = float(np.finfo(np.float32).eps)
TERMS_RTOL = 5 * EPS32  # 4 local terms + the reflected one, each rounded to float32, + the image's rounding
EXPLAIN_RTOL = 2 * EPS32  # per evaluation: the image's rounding and float64 re-association in the kernels
ATOL = 1e-12
W, H = 24, 18

# No shrinking: a drawn scene is already small, and shrinking re-renders it hundreds of times.
PROFILE = settings(max_examples=40, deadline=None, derandomize=True, print_blob=True,
                   phases=(Phase.explicit, Phase.generate),
                   suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])


class Case:
    """A drawn scene and render options, printed as the features drawn (not the arrays)."""

    def __init__(self, scene, options, features):
        self.scene, self.options, self.features = scene, options, features

    def render(self, shading, terms=True):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", rs.ShadingWarning)  # bump maps that flat and Gouraud ignore, on purpose
            return rs.render(self.scene, shading, terms=terms, **self.options)

    def __repr__(self):
        return f"Case({self.options}, {self.features})"

unit = st.floats(0.0, 1.0, allow_nan=False)
rgb = st.tuples(unit, unit, unit)


@st.composite
def textures(draw):
    h, w = draw(st.integers(1, 6)), draw(st.integers(1, 6))
    seed = draw(st.integers(0, 2 ** 16))
    texels = np.random.default_rng(seed).uniform(0.0, 1.0, (h, w, 3))
    wrap, filt = draw(st.sampled_from(["repeat", "clamp"])), draw(st.sampled_from(["bilinear", "mipmap"]))
    tiling = (draw(st.sampled_from([1.0, 2.0, 0.5, 3.7])), draw(st.sampled_from([1.0, 3.0, 0.7])))
    return rs.Texture(texels, wrap=wrap, filter=filt, tiling=tiling, name=f"{h}x{w} {wrap} {filt} {tiling}")


@st.composite
def materials(draw, bump_ok):
    maps = {slot: draw(st.none() | textures()) for slot in ("ka_map", "kd_map", "ks_map", "ke_map", "ao_map")}
    ks = draw(st.sampled_from([0.0, 0.3]) | rgb)
    ke = draw(st.sampled_from([0.0, 0.0, 0.25]) | rgb)
    bump = None
    if bump_ok and draw(st.booleans()):
        bump = rs.HeightMap.dimples(4, 0.3, resolution=16, scale=draw(st.sampled_from([0.02, -0.05])),
                                    tiling=(2.0, 2.0))
    normal_map = draw(st.none() | textures())  # random texels: normals bent every way, some past the horizon
    # The strength and the scale only with their maps (Material refuses them alone).
    ao_strength = draw(st.sampled_from([1.0, 0.6])) if maps["ao_map"] is not None else 1.0
    normal_scale = draw(st.sampled_from([1.0, 0.5, 2.0])) if normal_map is not None else 1.0
    with warnings.catch_warnings():  # a small random map may bend every normal past the horizon: on purpose
        warnings.simplefilter("ignore", rs.NormalMapWarning)
        return rs.Material(kd=draw(rgb), ka=draw(rgb), ks=ks, shininess=draw(st.sampled_from([1.0, 8.0, 40.0, 15.5])),
                           specular=draw(st.sampled_from(["phong", "blinn"])), bump=bump, ke=ke,
                           ka_colors=draw(st.booleans()), ao_strength=ao_strength, normal_map=normal_map,
                           normal_scale=normal_scale, **maps)


def _coloured(mesh, mode, seed):
    if mode is None:
        return mesh
    rng = np.random.default_rng(seed)
    n = len(mesh.vertices) if mode == "vertex" else len(mesh.faces)
    return rs.Mesh(mesh.vertices, mesh.faces, normals=mesh.normals, uvs=mesh.uvs, crease_angle=mesh.crease_angle,
                   colors=rng.uniform(0.0, 1.0, (n, 3)), color_mode=mode, name=mesh.name)


@st.composite
def lights(draw):
    kind = draw(st.sampled_from(["point", "directional", "spot"]))
    shadows = draw(st.booleans())
    colour = draw(st.sampled_from([1.0, (1.0, 0.6, 0.3)]))
    if kind == "directional":
        return rs.DirectionalLight((-0.4, -1.0, -0.5), intensity=draw(st.sampled_from([0.5, 1.0])), color=colour,
                                   shadows=shadows)
    law = draw(st.sampled_from(["none", "inverse_square", "heuristic"]))
    intensity = {"none": 1.0, "inverse_square": 12.0, "heuristic": 4.0}[law]
    position = draw(st.sampled_from([(1.5, 2.5, 1.5), (-1.0, 2.0, 2.5)]))
    if kind == "point":
        return rs.PointLight(position, intensity=intensity, attenuation=law, k=0.5, color=colour, shadows=shadows)
    # Aimed at the sphere with a cone narrower than the scene: pixels outside it, between the cones, inside.
    return rs.SpotLight(position, direction=-np.asarray(position), intensity=intensity, attenuation=law, k=0.5,
                        color=colour, shadows=shadows, exponent=draw(st.sampled_from([1.0, 8.0])),
                        inner_angle=draw(st.sampled_from([5.0, 12.0])), outer_angle=draw(st.sampled_from([15.0, 25.0])))


@st.composite
def cases(draw):
    shape = draw(st.sampled_from(["icosphere", "uv_sphere", "cube"]))
    obj = {"icosphere": lambda: rs.shapes.icosphere(1), "uv_sphere": lambda: rs.shapes.uv_sphere(6, 10),
           "cube": lambda: rs.shapes.cube(1.2)}[shape]()
    if obj.uvs is None:  # the cube has none: a spherical mapping, for its maps and bump map
        obj = rs.Mesh(obj.vertices, obj.faces, normals=obj.normals, uvs=rs.bump.spherical_uvs(obj.vertices),
                      crease_angle=30.0, name=obj.name)
    floor = rs.shapes.plane(5.0, subdivisions=2, center=(0.0, -1.0, 0.0), normal="+y")
    obj = _coloured(obj, draw(st.sampled_from([None, "vertex", "face"])), draw(st.integers(0, 99)))
    floor = _coloured(floor, draw(st.sampled_from([None, "vertex", "face"])), draw(st.integers(0, 99)))
    floor_mat = draw(materials(bump_ok=False))
    rho = draw(st.sampled_from([0.0, 0.0, 0.4]))
    if rho:
        floor_mat = rs.Material(kd=floor_mat.kd, ka=floor_mat.ka, ks=floor_mat.ks, shininess=floor_mat.shininess,
                                kd_map=floor_mat.kd_map, reflectivity=rho, ke=floor_mat.ke, ke_map=floor_mat.ke_map,
                                ka_colors=floor_mat.ka_colors, ao_map=floor_mat.ao_map,
                                ao_strength=floor_mat.ao_strength)
    scene = rs.Scene([rs.Model(obj, draw(materials(bump_ok=True))), rs.Model(floor, floor_mat)],
                     lights=draw(st.lists(lights(), min_size=1, max_size=2)),
                     camera=rs.Camera(eye=(0.3, 1.4, 4.0), target=(0.0, -0.4, 0.0), width=W, height=H),
                     ambient=draw(st.sampled_from([0.0, 0.1, (0.1, 0.05, 0.2)])),
                     background=draw(st.sampled_from([(0.0, 0.0, 0.0), (0.2, 0.3, 0.4)])))
    options = dict(interpolation=draw(st.sampled_from(["perspective", "screen"])),
                   backend=draw(st.sampled_from(["raycast", "raster"])), max_depth=draw(st.sampled_from([0, 1, 3])))
    features = [(m.mesh.name, m.mesh.prepared.color_mode,
                 {k: getattr(m.material, k).name for k in ("ka_map", "kd_map", "ks_map", "ke_map", "ao_map")
                  if getattr(m.material, k) is not None},
                 dict(ks=m.material.ks.tolist(), ke=m.material.ke.tolist(), ka_colors=m.material.ka_colors,
                      spec=m.material.specular, bump=m.material.bump is not None,
                      normal_map=m.material.normal_map is not None,
                      rho=m.material.reflectivity)) for m in scene.models]
    features.append([(type(light).__name__, getattr(light, "attenuation", ""), light.shadows)
                     for light in scene.lights])
    for key, value in options.items():  # what was drawn, for --hypothesis-show-statistics
        event(f"{key}={value}")
    for m in scene.models:
        event(f"colours={m.mesh.prepared.color_mode}")
        for slot, tex in zip(("ka_map", "kd_map", "ks_map", "ke_map", "ao_map"), m.material.maps):
            if tex is not None:
                event(f"{slot} {tex.wrap} {tex.filter}")
        if m.material.has_emission:
            event("emission")
        if m.material.ka_colors and m.mesh.prepared.color_mode is not None:
            event("ambient follows the colours")
        if m.material.bump is not None:
            event("bump map")
        if m.material.normal_map is not None:
            event("normal map")
        if m.material.reflectivity > 0:
            event("mirror")
    for light in scene.lights:
        event(f"{type(light).__name__} shadows={light.shadows}")
    return Case(scene, options, features)


def _close(a, b, rtol):
    a, b = np.asarray(a, np.float64), np.asarray(b, np.float64)
    return bool(np.all(np.abs(a - b) <= rtol * np.abs(b) + ATOL))


METHODS = ("flat", "gouraud", "phong")  # one test per method: a drawn method would favour the first


@pytest.mark.parametrize("shading", METHODS)
@PROFILE
@given(case=cases())
def test_terms_add_up_to_the_image(shading, case):
    frame, options = case.render(shading, "per_light"), dict(case.options, shading=shading)
    total = compose_terms(frame.terms)
    err = np.abs(total.astype(np.float64) - frame.image) - TERMS_RTOL * np.abs(frame.image.astype(np.float64))
    y, x, c = np.unravel_index(np.argmax(err), err.shape)
    assert err.max() <= ATOL, (options, (x, y, c), float(total[y, x, c]), float(frame.image[y, x, c]))
    # And the lights add up to the summed terms: L float32 roundings, + the sum's own.
    n = len(case.scene.lights)
    for term in ("diffuse", "specular"):
        per = frame.terms[f"{term}_per_light"].astype(np.float64).sum(axis=0)
        np.testing.assert_allclose(per, frame.terms[term], rtol=(n + 1) * EPS32, atol=ATOL, err_msg=f"{options} {term}")


@pytest.mark.parametrize("shading", METHODS)
@PROFILE
@given(case=cases(), seed=st.integers(0, 2 ** 16))
def test_explain_equals_the_pixel(shading, case, seed):
    frame, options = case.render(shading), dict(case.options, shading=shading)
    rng = np.random.default_rng(seed)
    ys, xs = np.nonzero(frame.mask)
    picks = [(int(xs[i]), int(ys[i])) for i in rng.choice(len(xs), size=min(8, len(xs)), replace=False)]
    picks.append((0, 0))  # the corner: background or a surface, either way the pixel
    for x, y in picks:
        e = frame.explain(x, y)
        assert _close(e.total, frame.image[y, x], EXPLAIN_RTOL * (1 + len(e.bounces))), \
            (options, (x, y), e.total.tolist(), frame.image[y, x].tolist())
