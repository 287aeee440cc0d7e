"""The batched Phong kernel (shading/phong_fast.py) is the general Phong kernel bit for bit on the
scenes it is dispatched to, and the dispatch takes it exactly for those scenes."""

from __future__ import annotations

import dataclasses
import warnings

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import raycast_shade as rs
from raycast_shade.shading import shade as shade_mod
from raycast_shade.shading.inputs import prepare
from raycast_shade.shading.jit import variant
from raycast_shade.shading.mirror_rays import NO_RAYS
from raycast_shade.shading.phong import _PHONG
from raycast_shade.shading.normals import shading_normals
from raycast_shade.shading.phong import _PHONG_PACKETS
from raycast_shade.shading.phong_fast import _NO_NORMALS, _PHONG_FAST, _PHONG_FAST_SHADOWS, LANES, applies
from raycast_shade.shading.shade import resolve_methods

W, H = 40, 30


def _soup(seed, n=24):
    """Random triangles with random vertex normals, some flipped and some zero (every branch of
    the shading normal: reflected, cancelled), and one degenerate (zero-area) face."""
    rng = np.random.default_rng(seed)
    verts = rng.uniform(-1.0, 1.0, (3 * n, 3))
    verts[3:6] = verts[3]  # a degenerate face: its face normal is zero
    faces = np.arange(3 * n).reshape(n, 3)
    normals = rng.normal(size=verts.shape)
    normals[::4] *= -1.0
    normals[::5] = 0.0
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return rs.Mesh(verts, faces, normals=normals)


def _fast(k):
    """The batched kernel for the frame inputs ``k``: with shadow rays when it has a scene handle."""
    return _PHONG_FAST_SHADOWS if k.lighting.handle != 0 else _PHONG_FAST


def _both(scene, shading, hits):
    """The general kernel's (one shadow ray at a time, ``rtcOccluded1``) and the batched kernel's
    images of ``hits`` (each on a NaN-filled canvas)."""
    k = prepare(scene, scene.camera)
    modes = resolve_methods(scene, shading)
    assert applies(modes, k)
    general = np.full(hits.shape + (3,), np.nan, np.float32)
    fast = general.copy()
    normals = (general.copy(), general.copy())  # each kernel's shading normals (the "normal" buffer)
    variant(_PHONG, k)((hits.prim, hits.geom, hits.u, hits.v), k["G"], k["B"], k["L"], k["T"], k["face_off"],
                       k["materials"], k["cam"], k["background"], modes, (general, normals[0], NO_RAYS), 0)
    _fast(k)(hits.prim, hits.geom, hits.u, hits.v, k["G"], k["L"], k["face_off"], k["materials"], k["cam"],
             k["background"], modes, (fast, normals[1], NO_RAYS))
    assert _same_bits(*normals), "the batched kernel's shading normals differ from the general kernel's"
    return general, fast


def _same_bits(a, b):
    return np.array_equal(a.view(np.uint32), b.view(np.uint32))


materials = st.builds(
    lambda kd, ks, t, spec, ke: rs.Material(kd=kd, ks=ks, shininess=t, specular=spec, ke=ke),
    st.tuples(*[st.floats(0.0, 1.0)] * 3), st.sampled_from([0.0, 0.3, (0.0, 0.5, 1.0), 1.0]),
    st.one_of(st.integers(1, 300), st.sampled_from([0.5, 37.25, 5000.0, 4096.0])),
    st.sampled_from(["phong", "blinn"]), st.sampled_from([0.0, (0.1, 0.0, 0.2)]))
points = st.tuples(*[st.floats(-3.0, 3.0)] * 3)
lights = st.one_of(  # each casting shadows or not
    st.builds(lambda p, i, law, sh: rs.PointLight(p, intensity=i, attenuation=law, k=0.5, shadows=sh), points,
              st.floats(0.1, 20.0), st.sampled_from(["none", "inverse_square", "heuristic"]), st.booleans()),
    st.builds(lambda d, i, sh: rs.DirectionalLight(d, intensity=i, shadows=sh),
              points.filter(lambda d: np.linalg.norm(d) > 0.1), st.floats(0.1, 2.0), st.booleans()),
    st.builds(lambda p, n, law, sh: rs.SpotLight(p, direction=(-p[0], -p[1], -p[2]), intensity=3.0, exponent=n,
                                                 inner_angle=15, outer_angle=35, attenuation=law, shadows=sh),
              points.filter(lambda p: np.linalg.norm(p) > 0.5), st.sampled_from([0.0, 2.0, 7.0, 2.5]),
              st.sampled_from(["none", "inverse_square"]), st.booleans()))


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(seed=st.integers(0, 2 ** 16), mats=st.lists(materials, min_size=3, max_size=3),
       lits=st.lists(lights, min_size=1, max_size=3), ortho=st.booleans(), eye=points.filter(lambda e: np.linalg.norm(e) > 1.6 and abs(e[0]) + abs(e[2]) > 0.5),
       methods=st.sampled_from(["phong", ("phong", "flat", "phong"), ("gouraud", "phong", "phong")]))
def test_the_batched_kernel_is_the_general_one_bit_for_bit(seed, mats, lits, ortho, eye, methods):
    """Random scenes (both specular models, whole and fractional shininess, every light kind and
    attenuation law, lights casting shadows or not, perspective and orthographic), the hit buffer
    Embree casts and an arbitrary one (barycentrics outside the triangle, every face, a mix of
    methods): the same bits."""
    cam = (rs.Camera(eye=eye, width=W, height=H, projection="orthographic", ortho_height=3.0) if ortho
           else rs.Camera(eye=eye, width=W, height=H, fov=50))
    models = [rs.Model(_soup(seed), mats[0]), rs.Model(rs.shapes.icosphere(1, radius=0.6), mats[1]),
              rs.Model(rs.shapes.torus(0.9, 0.2, 12, 6), mats[2])]
    scene = rs.Scene(models, lights=lits, camera=cam, ambient=0.1, background=(0.1, 0.2, 0.3))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        hits = rs.render(scene, methods).hits
    general, fast = _both(scene, methods, hits)
    assert _same_bits(general, fast)
    rng = np.random.default_rng(seed)
    geo = scene.geometry
    counts = np.diff(geo.face_offsets)
    geom = rng.integers(-1, len(models), (H, W)).astype(np.int32)
    prim = np.where(geom >= 0, (rng.uniform(size=(H, W)) * counts[np.maximum(geom, 0)]).astype(np.int32), -1)
    u = rng.uniform(-0.2, 1.2, (H, W)).astype(np.float32)
    v = rng.uniform(-0.2, 1.2, (H, W)).astype(np.float32)
    made = rs.HitBuffer(prim.astype(np.int32), np.where(prim >= 0, geom, -1).astype(np.int32), u, v,
                        np.ones((H, W), np.float32))
    general, fast = _both(scene, methods, made)
    assert _same_bits(general, fast)
    assert np.isfinite(fast[prim >= 0]).any()  # not vacuous: lanes were shaded


def test_full_and_partial_batches_and_rows_without_hits():
    """More hits than two batches hold, and a last batch part full: the same bits."""
    cam = rs.Camera(eye=(0.0, 0.0, 1.6), width=3 * LANES + 5, height=9, fov=10)
    scene = rs.Scene([rs.Model(rs.shapes.icosphere(2), rs.Material(ks=0.4, shininess=12))],
                     lights=[rs.PointLight((1.0, 2.0, 3.0), intensity=9.0, attenuation="inverse_square")], camera=cam)
    hits = rs.render(scene).hits
    assert (hits.prim >= 0).sum() > 2 * LANES
    general, fast = _both(scene, "phong", hits)
    assert _same_bits(general, fast)


@pytest.mark.parametrize("material", [
    rs.Material(ks=0.5, shininess=40.0),  # Phong, a whole power: six squaring passes
    rs.Material(ks=0.5, shininess=13.0, specular="blinn"),  # Blinn-Phong, odd bits
    rs.Material(ks=0.5, shininess=37.25),  # a fractional power: pow per lane
    rs.Material(ks=0.5, shininess=5000.0, specular="blinn"),  # beyond 4096: pow per lane
    rs.Material(ks=0.0, shininess=40.0, ke=(0.1, 0.0, 0.2)),  # no specular term; emission
], ids=["phong-40", "blinn-13", "phong-37.25", "blinn-5000", "no-specular"])
def test_one_model_batches_are_the_general_kernels_with_and_without_normals(material):
    """A one-model frame: every batch holds one model's row, so the kernel reads which reflectance
    models and powers the batch needs from lane 0 (not from each lane) and never reads a pixel's
    model; full batches and a part-full last one, the image with the normals asked for and without
    (the scatter's two stores) are the general kernel's bit for bit."""
    cam = rs.Camera(eye=(0.3, 0.5, 1.9), width=2 * LANES + 7, height=23, fov=35)
    scene = rs.Scene([rs.Model(rs.shapes.icosphere(2), material)],
                     lights=[rs.PointLight((1.0, 2.0, 3.0), intensity=9.0, attenuation="inverse_square"),
                             rs.DirectionalLight((-0.3, -1.0, -0.5), intensity=0.7)], camera=cam, ambient=0.1)
    hits = rs.render(scene).hits
    assert (hits.prim >= 0).sum() > 2 * LANES
    general, fast = _both(scene, "phong", hits)
    assert _same_bits(general, fast)
    k = prepare(scene, scene.camera)
    alone = np.full(hits.shape + (3,), np.nan, np.float32)
    _PHONG_FAST(hits.prim, hits.geom, hits.u, hits.v, k["G"], k["L"], k["face_off"], k["materials"], k["cam"],
                k["background"], resolve_methods(scene, "phong"), (alone, _NO_NORMALS, NO_RAYS))
    assert _same_bits(alone, general)
    lit = fast[hits.prim >= 0]
    assert np.isfinite(lit).all() and np.ptp(lit[:, 0]) > 0.0  # not vacuous: shaded, and not flat


def test_the_normals_it_writes_are_those_the_frame_reports():
    """Given a normal array, the kernel writes each pixel's shading normal (zero on the background):
    ``frame.normal``'s values (:func:`shading_normals`) bit for bit, and the same image."""
    scene = rs.Scene([rs.Model(_soup(3), rs.Material(ks=0.5, shininess=9)),
                      rs.Model(rs.shapes.torus(0.9, 0.2, 12, 6), rs.Material(ks=0.2, specular="blinn"))],
                     lights=[rs.PointLight((1.0, 2.0, 3.0), intensity=9.0, attenuation="heuristic")],
                     camera=rs.Camera(eye=(0.4, 0.8, 3.0), width=W, height=H))
    hits = rs.render(scene).hits
    k = prepare(scene, scene.camera)
    modes = resolve_methods(scene, "phong")
    image = np.full(hits.shape + (3,), np.nan, np.float32)
    normal = image.copy()
    _fast(k)(hits.prim, hits.geom, hits.u, hits.v, k["G"], k["L"], k["face_off"], k["materials"], k["cam"],
             k["background"], modes, (image, normal, NO_RAYS))
    expected = shading_normals(scene, scene.camera, hits, "phong")
    assert _same_bits(normal, expected) and (normal[hits.prim < 0] == 0.0).all()
    assert (np.abs(np.linalg.norm(normal[hits.prim >= 0], axis=-1) - 1.0) < 1e-6).all()
    general, _ = _both(scene, "phong", hits)
    assert _same_bits(image, general)


class _Spy:
    """A registry (or one kernel) whose kernels count their calls."""

    def __init__(self, registry):
        self.calls = 0
        if isinstance(registry, dict):
            self.kernels = {key: self._wrap(fn) for key, fn in registry.items()}
        else:
            self.kernels = self._wrap(registry)

    def _wrap(self, fn):
        def spy(*args):
            self.calls += 1
            return fn(*args)
        return spy


def _scene(material=None, light=None, mesh=None):
    mesh = mesh if mesh is not None else rs.shapes.uv_sphere(8, 16)
    return rs.Scene([rs.Model(mesh, material or rs.Material(ks=0.5, shininess=20))],
                    lights=[light or rs.PointLight((2.0, 3.0, 4.0), intensity=20.0)],
                    camera=rs.Camera(eye=(0.0, 0.0, 3.0), width=W, height=H))


CHECKER = rs.Texture.checker(squares=4, texels_per_square=4)
CASES = {
    "plain": (_scene(), "phong", True),
    "blinn, spot, heuristic": (_scene(rs.Material(ks=0.3, specular="blinn"),
                                      rs.SpotLight((0.0, 2.0, 2.0), direction=(0.0, -1.0, -1.0), attenuation="heuristic")),
                               "phong", True),
    "shadows": (_scene(light=rs.PointLight((2.0, 3.0, 4.0), intensity=20.0, shadows=True)), "phong", True),
    "texture": (_scene(rs.Material(kd_map=CHECKER)), "phong", False),
    "texture, shadows": (_scene(rs.Material(kd_map=CHECKER), rs.PointLight((2.0, 3.0, 4.0), shadows=True)),
                         "phong", False),
    "bump": (_scene(rs.Material(bump=rs.HeightMap.dimples(4, 0.3, resolution=16, scale=0.02))), "phong", False),
    "normal map": (_scene(rs.Material(normal_map=rs.Texture(np.full((2, 2, 3), (0.6, 0.4, 0.9))))), "phong", False),
    "bump under Gouraud": (_scene(rs.Material(bump=rs.HeightMap.dimples(4, 0.3, resolution=16, scale=0.02))),
                           "gouraud", None),
}


@pytest.mark.parametrize("name", list(CASES))
def test_the_dispatch_takes_the_batched_kernel_exactly_where_it_applies(name, monkeypatch):
    scene, shading, fast = CASES[name]
    spy_fast, spy_general = _Spy(shade_mod._PHONG_FAST), _Spy(shade_mod._PHONG)
    spy_fast_shadows = _Spy(shade_mod._PHONG_FAST_SHADOWS)  # the batched kernel with shadow rays
    spy_packets = _Spy(shade_mod._PHONG_PACKETS)  # the general kernel with shadow packets
    monkeypatch.setattr(shade_mod, "_PHONG_FAST", spy_fast.kernels)
    monkeypatch.setattr(shade_mod, "_PHONG_FAST_SHADOWS", spy_fast_shadows.kernels)
    monkeypatch.setattr(shade_mod, "_PHONG", spy_general.kernels)
    monkeypatch.setattr(shade_mod, "_PHONG_PACKETS", spy_packets.kernels)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        frame = rs.render(scene, shading)
    general = spy_general.calls + spy_packets.calls
    shadowed = any(light.shadows for light in scene.lights)
    batched = (spy_fast_shadows if shadowed else spy_fast).calls
    assert (spy_fast_shadows if not shadowed else spy_fast).calls == 0  # the variant of the frame's shadows
    assert (batched, general) == {True: (1, 0), False: (0, 1), None: (0, 0)}[fast]
    if fast:  # and the image is the general kernel's
        general, batched = _both(scene, shading, frame.hits)
        assert _same_bits(general, batched) and _same_bits(frame.image, batched)


# -- shadowed frames: the batched kernel traces the shadow rays of its lanes as 16-ray packets -------------


def _alpha_grid(n=4):
    """A 4x4 grid of quads at y = 0.3 whose alpha map clears every other cell: shadow rays pass
    through the clear texels (visibility/alpha.py's occlusion filter sees packets too)."""
    xs = np.linspace(-1.0, 1.0, n + 1)
    v = np.array([(x, 0.3, z) for z in xs for x in xs])
    faces = []
    for i in range(n):
        for j in range(n):
            a = i * (n + 1) + j
            faces += [(a, a + n + 2, a + 1), (a, a + n + 1, a + n + 2)]
    cover = (np.indices((n, n)).sum(0) % 2 == 0).astype(np.float64)
    amap = rs.Texture(np.repeat(cover[..., None], 3, axis=2), wrap="clamp", name="alpha")
    return rs.Model(rs.Mesh(v, np.array(faces), uvs=(v[:, [0, 2]] + 1.0) / 2.0),
                    rs.Material(kd=0.6, alpha_map=amap, alpha_cutoff=0.5))


def _shadowed(kind, width=67, height=53):
    """Spheres over a floor under a point light, a sun and a spot light casting shadows and a point
    light casting none; ``"alpha"``: a masked grid over the floor instead of the spheres."""
    floor = rs.Model(rs.shapes.plane(6.0, subdivisions=3, center=(0.0, -0.7, 0.0), normal="+y"),
                     rs.Material(kd=0.7, ks=0.2, shininess=10.0))
    lights = [rs.PointLight((1.5, 3.0, 2.0), intensity=12.0, attenuation="inverse_square", shadows=True),
              rs.DirectionalLight((-0.4, -1.0, -0.3), intensity=0.4, shadows=True),
              rs.SpotLight((-1.0, 2.5, 1.0), direction=(0.4, -1.0, -0.3), intensity=6.0, inner_angle=15.0,
                           outer_angle=25.0, shadows=True, attenuation="heuristic"),
              rs.PointLight((0.0, 1.0, 4.0), intensity=0.5)]
    models = [rs.Model(rs.shapes.icosphere(3, radius=0.6), rs.Material(kd=(0.8, 0.3, 0.2), ks=0.4, shininess=30.0)),
              rs.Model(rs.shapes.icosphere(2, radius=0.25, center=(0.8, -0.2, 0.5)),
                       rs.Material(kd=0.5, ks=0.3, specular="blinn", shininess=7.5)), floor]
    if kind == "alpha":
        models = [_alpha_grid(), floor]
    cam = rs.Camera(eye=(0.5, 1.5, 3.5), target=(0.0, -0.3, 0.0), width=width, height=height,
                    **({"projection": "orthographic", "ortho_height": 3.0} if kind == "ortho" else {}))
    return rs.Scene(models, lights=lights, camera=cam, ambient=0.1)


@pytest.mark.parametrize("kind", ["spheres", "ortho", "alpha"])
def test_shadowed_frames_are_the_general_kernels_bit_for_bit(kind):
    """Every light kind casting shadows (a spot light's cone too), alpha-masked occluders, odd sizes
    (a last batch part full): the batched kernel's image and normals are those of the general
    kernel tracing one ray at a time, and there are shadows to lose (not vacuous)."""
    scene = _shadowed(kind)
    frame = rs.render(scene, "phong")
    general, fast = _both(scene, "phong", frame.hits)
    assert _same_bits(general, fast) and _same_bits(frame.image, fast)
    plain = rs.render(scene.replace(lights=[dataclasses.replace(light, shadows=False) for light in scene.lights]))
    lost = np.any(fast != plain.image, axis=-1)
    assert lost.mean() > 0.05, lost.mean()
    if kind == "alpha":  # light through the clear cells: the floor brighter than under an opaque grid
        grid = scene.models[0]
        opaque = scene.replace(models=[rs.Model(grid.mesh, rs.Material(kd=0.6)), scene.models[1]])
        through = (fast > rs.render(opaque, "phong").image).any(axis=-1)[frame.hits.geom == 1]
        assert through.mean() > 0.05, through.mean()


def test_the_shadowed_kernel_is_the_packet_kernel_on_a_banded_frame():
    """Large enough for the banded path: the batched kernel's lanes cross rows and bands differently
    from the packet kernel's 4x4 tiles; the rays, and so the image, are the same."""
    scene = _shadowed("spheres", 1024, 512)
    frame = rs.render(scene, "phong")
    k = prepare(scene, scene.camera)
    hits = frame.hits
    tiles = np.full(hits.shape + (3,), np.nan, np.float32)
    variant(_PHONG_PACKETS, k)((hits.prim, hits.geom, hits.u, hits.v), k["G"], k["B"], k["L"], k["T"], k["face_off"],
                               k["materials"], k["cam"], k["background"], resolve_methods(scene, "phong"),
                               (tiles, _NO_NORMALS, NO_RAYS), 0)
    assert _same_bits(frame.image, tiles)


@pytest.mark.parametrize("shadows", [False, True])
def test_on_a_mesh_beyond_the_caches_the_prefetching_gather_is_the_general_kernel_bit_for_bit(shadows):
    """A mesh whose gathered arrays exceed PREFETCH_BYTES takes the gather that prefetches rows
    ahead (the faces as they are queued, the vertices a pass before they are read): the image and
    normals are still the general kernel's bit for bit, with and without shadow rays."""
    from raycast_shade.common.prefetch import PREFETCH_BYTES

    mesh = rs.shapes.icosphere(8)  # 1.31 M triangles, about 80 MB gathered
    k_light = rs.PointLight((2.0, 3.0, 4.0), intensity=20.0, shadows=shadows)
    models = [rs.Model(mesh, rs.Material(ks=0.5, shininess=20))]
    if shadows:  # a floor for the sphere's shadow
        models.append(rs.Model(rs.shapes.plane(6.0, center=(0.0, -1.0, 0.0), normal="+y"), rs.Material(kd=0.6)))
    scene = rs.Scene(models,
                     lights=[k_light], camera=rs.Camera(eye=(0.5, 1.0, 3.0), target=(0.0, -0.5, 0.0),
                                                        width=96, height=72))
    k = prepare(scene, scene.camera)
    assert sum(a.nbytes for a in k["G"]) > PREFETCH_BYTES  # the prefetching path, not vacuous
    frame = rs.render(scene, "phong")
    general, fast = _both(scene, "phong", frame.hits)
    assert _same_bits(general, fast) and _same_bits(frame.image, fast)
    if shadows:  # the sphere's shadow on the floor: shadow rays traced, some blocked
        plain = rs.render(scene.replace(lights=[dataclasses.replace(k_light, shadows=False)]), "phong")
        assert np.any(fast != plain.image, axis=-1).mean() > 0.02
