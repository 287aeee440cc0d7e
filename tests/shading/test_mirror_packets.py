"""Mirror bounces in 16-ray packets, band by band (issue 27).

The reflective pixels of each 4x4 tile of the frame trace their bounces as one
``rtcIntersect16`` packet (:mod:`raycast_shade.shading.mirrors`), and ``render`` runs them
after each band is shaded. A pixel's result must not depend on which pixels share its
packet or band: these tests cut the same hits into arbitrary pieces (cutting tiles) and
compare bit for bit, and check that the packets see through an alpha mask's clear texels
as single rays do.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

import raycast_shade as rs
from raycast_shade.shading.inputs import prepare
from raycast_shade.shading.mirrors import trace_mirrors
from raycast_shade.visibility import bands

from tests.shading.test_mirror import LIGHTS, PERFECT, SPHERE_MAT, mirror_mesh
from tests.visibility.test_alpha import _masked_and_cut, _plane


def _hall(width=61, height=46):
    """Two facing mirrors (one half local shade) and a textured sphere between them: rays bounce
    up to many times, some end on the sphere, some escape; mirror edges run through tiles."""
    lower = rs.shapes.plane(size=6.0, center=(0.0, 0.0, -1.0), normal="+z")
    upper = rs.shapes.plane(size=6.0, center=(0.0, 0.0, 1.0), normal="-z")
    ball = rs.shapes.uv_sphere(12, 24, radius=0.4, center=(0.8, 0.3, 0.0))
    half = rs.Material(ka=0.2, kd=(0.3, 0.5, 0.2), ks=0.3, shininess=20, reflectivity=0.5)
    textured = rs.Material(kd_map=rs.Texture.checker(8, 4), ks=0.4, shininess=30, reflectivity=0.25)
    cam = rs.Camera(eye=(-2.5, 0.2, 0.3), target=(1.0, 0.1, -0.2), width=width, height=height, fov=70)
    return rs.Scene([rs.Model(lower, half), rs.Model(upper, PERFECT), rs.Model(ball, textured)],
                    lights=[rs.PointLight((0.0, 0.0, 0.5), intensity=0.6, shadows=True)], camera=cam, ambient=0.1)


_HALL = _hall()
_HITS = rs.cast_camera(_HALL.geometry, _HALL.camera)
_LOCAL = rs.shade(_HALL, _HALL.camera, _HITS)


def _traced(cuts, depth):
    """The hall's mirrors traced over the whole frame, and over the rows cut at ``cuts``
    (each piece with its own ``y0``), as two images."""
    k = prepare(_HALL, _HALL.camera)
    whole = trace_mirrors(_HALL, _HALL.camera, _HITS, _LOCAL.copy(), depth, k)
    pieces = _LOCAL.copy()
    edges = [0, *sorted(set(cuts)), _HITS.shape[0]]
    for a, b in zip(edges[:-1], edges[1:]):
        if b > a:
            part = rs.HitBuffer(*(np.ascontiguousarray(x[a:b]) for x in _HITS))
            out = np.ascontiguousarray(pieces[a:b])
            trace_mirrors(_HALL, _HALL.camera, part, out, depth, k, y0=a)
            pieces[a:b] = out
    return whole, pieces


def test_the_hall_bounces_many_times():
    """The scene the cut tests use is not trivial: most pixels reflect, and depth 3 differs from
    depth 1 and depth 8 from depth 3."""
    assert np.isin(_HITS.geom, (0, 1)).mean() > 0.6
    images = [_traced([], d)[0] for d in (1, 3, 8)]
    assert np.abs(images[1] - images[0]).max() > 1e-2 and np.abs(images[2] - images[1]).max() > 1e-4


@settings(max_examples=12, deadline=None)
@given(cuts=st.lists(st.integers(1, 45), max_size=4), depth=st.sampled_from([1, 2, 5]))
def test_any_cut_of_the_rows_traces_the_same_bits(cuts, depth):
    """Pieces cut anywhere (through the 4x4 tiles, so their pixels travel in other packets)
    give the whole frame's image, bit for bit."""
    whole, pieces = _traced(cuts, depth)
    np.testing.assert_array_equal(pieces, whole)
    assert not np.array_equal(whole, _LOCAL)


@pytest.fixture
def small_bands(monkeypatch):
    monkeypatch.setattr(bands, "BAND_ROWS", 16)
    monkeypatch.setattr(bands, "MIN_PIXELS", 0)


def _whole(scene, **kw):
    """``render`` through the whole-frame path."""
    import sys

    module = sys.modules["raycast_shade.render"]
    saved = module._banded
    try:
        module._banded = lambda *a: False
        return rs.render(scene, **kw)
    finally:
        module._banded = saved


@pytest.mark.parametrize("kw", [dict(max_depth=1), dict(max_depth=6, shading="gouraud"),
                                dict(max_depth=2, samples=2, buffers=("zdepth",))], ids=["1", "6-gouraud", "2-samples"])
@pytest.mark.usefixtures("small_bands")
def test_a_banded_mirror_frame_is_the_whole_frame(kw):
    """Bands of 16 rows start at rows 0, 15, 31, ...: they cut the 4x4 tiles."""
    banded, whole = rs.render(_HALL, **kw), _whole(_HALL, **kw)
    assert callable(banded.__dict__["_hits"]) and not callable(whole.__dict__["_hits"])
    np.testing.assert_array_equal(banded.image, whole.image)
    assert banded.timings["mirror"] > 0


@pytest.mark.usefixtures("small_bands")
def test_banded_mirror_packets_pass_the_clear_texels():
    """tests/visibility/test_alpha.py's mirror scene, banded: the camera sees only a mirror floor,
    which shows a masked grid and a blue ceiling behind it; the packets see the ceiling through
    the clear cells as through the cut grid's holes."""
    cam = rs.Camera(eye=(0.0, 0.0, 4.0), target=(0, 0, -1.0), up=(0, 1, 0), fov=40.0, width=96, height=96)
    mirror = _plane(-1.0, kd=0.0, ka=0.0, reflectivity=1.0)
    ceiling = _plane(7.0, size=20.0, kd=(0.1, 0.2, 0.9), ka=(0.1, 0.2, 0.9))
    masked, cut = _masked_and_cut(z=5.0, kd=(0.9, 0.2, 0.2), ka=(0.9, 0.2, 0.2))
    lights = [rs.DirectionalLight((0.0, 0.0, 1.0))]
    a = rs.Scene([masked, mirror, ceiling], lights=lights, camera=cam, ambient=0.3)
    b = rs.Scene([cut, mirror, ceiling], lights=lights, camera=cam, ambient=0.3)
    fa, fb = rs.render(a, max_depth=1), rs.render(b, max_depth=1)
    assert callable(fa.__dict__["_hits"])  # banded
    differ = np.any(fa.image != fb.image, axis=-1)
    assert differ.mean() < 0.005, differ.sum()  # cell edges only, where float rounding picks a side
    red = fa.image[..., 0] > 2 * fa.image[..., 2]
    blue = fa.image[..., 2] > 2 * fa.image[..., 0]
    assert red.mean() > 0.02 and blue.mean() > 0.3
    # Inside the grid's reflection, both: the covered cells and the ceiling through the clear ones.
    rows, cols = np.nonzero(red)
    box = np.zeros_like(red)
    box[rows.min() + 4:rows.max() - 3, cols.min() + 4:cols.max() - 3] = True
    assert (blue & box).sum() > 100 and (red & box).sum() > 100
    np.testing.assert_array_equal(fa.image, _whole(a, max_depth=1).image)


def test_a_mirror_frame_times_its_bounces_apart():
    sphere = rs.shapes.icosphere(2, radius=0.5, center=(0.3, 0.2, 1.0))
    scene = rs.Scene([rs.Model(mirror_mesh(), PERFECT), rs.Model(sphere, SPHERE_MAT)], lights=LIGHTS,
                     camera=rs.Camera(eye=(0.9, 1.2, 4.0), target=(0.0, 0.0, 0.4), width=40, height=30))
    frame = rs.render(scene, max_depth=1)
    assert frame.timings["mirror"] > 0 and "mirror" not in rs.render(scene, max_depth=0).timings


@given(p=st.floats(allow_nan=True, allow_infinity=True), n=st.floats(-1.0, 1.0),
       unit=st.floats(1e-300, 1e300))
@settings(max_examples=300, deadline=None)
def test_the_mirror_origin_offset_is_the_shadow_nudge_bit_for_bit(p, n, unit):
    """The mirror rays' origin offset (``frexp``/``ldexp`` replaced by the exponent's bits) is
    :func:`~raycast_shade.shading.shadows._nudge` everywhere: near zero, across powers of two,
    subnormal steps, inf and NaN."""
    from raycast_shade.shading.mirror_rays import _offset
    from raycast_shade.shading.shadows import _nudge

    for q in (p, np.nextafter(p, 0.0), np.ldexp(1.0, int(np.clip(np.frexp(p)[1], -1074, 1023))) if np.isfinite(p) else p):
        a, b = _offset(q, n, unit), _nudge(q, n, unit)
        assert a == b or (np.isnan(a) and np.isnan(b)), (q, n, unit, a, b)


def test_the_mirror_kernel_asks_the_query_for_its_packets():
    """The packets reach Embree only through the visibility stage's query for secondary rays
    (:mod:`raycast_shade.visibility.secondary`: its raw calls are checked in
    tests/visibility/test_embree_binding.py), with a packet the kernel task allocated itself
    (``closest_packet``), never through a raw Embree symbol or an address taken here."""
    import ast
    import pathlib

    import raycast_shade.shading as pkg

    raw = {"intersect1", "intersect8", "intersect16", "occluded1", "occluded16", "intersect16_packet"}
    source = (pathlib.Path(pkg.__file__).parent / "mirrors.py").read_text(encoding="utf-8")
    calls = {}
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Call):
            name = node.func.attr if isinstance(node.func, ast.Attribute) else getattr(node.func, "id", None)
            calls.setdefault(name, []).append(node)
    assert not [name for name in raw if name in calls], "raw Embree calls in mirrors.py"
    assert "ctypes" not in source
    (trace,) = calls["trace_closest"]
    assert [ast.unparse(a) for a in trace.args] == ["handle", "Q"]
    (make,) = calls["closest_packet"]
    assert "            Q = closest_packet(flags)" in source  # per kernel task, reused by its tiles and bounces
    assert {"set_closest_rays", "closest_hit"} <= set(calls)


def test_the_prefetch_hint_compiles_to_a_prefetch_and_changes_nothing():
    """The mirror kernel's cache hint (:func:`~raycast_shade.common.prefetch.prefetch`) is an
    x86 ``prefetch`` instruction, whatever row it names (first, last, of 1-D and 2-D arrays of
    any dtype), and a loop that issues it computes what the same loop without it computes."""
    from numba import njit

    from raycast_shade.common.prefetch import prefetch as _prefetch

    @njit
    def sums(rows, ids, hint):
        total = 0.0
        for k in range(ids.shape[0]):
            if hint:
                _prefetch(rows, ids[min(k + 3, ids.shape[0] - 1)])
                _prefetch(ids, k)
            total += rows[ids[k], 0] + 2.0 * rows[ids[k], 2]
        return total

    rng = np.random.default_rng(27)
    rows = rng.normal(size=(1000, 3))
    ids = rng.integers(0, 1000, 4000).astype(np.int32)
    ids[:2] = (0, 999)
    assert sums(rows, ids, True) == sums(rows, ids, False) == float(
        sum(rows[i, 0] + 2.0 * rows[i, 2] for i in ids))
    asm = sums.inspect_asm(sums.signatures[0])
    assert "prefetcht0" in asm
    with pytest.raises(Exception, match="_prefetch|prefetch"):
        njit(lambda a: _prefetch(a, 0))(1.5)  # not an array: refused at typing


@pytest.mark.parametrize("depth", [1, 3])
def test_prefetching_the_gathers_changes_no_bit_of_the_mirror_image(depth, monkeypatch):
    """The hall's mirror bounces with the gathers of the tiles ahead prefetched (the threshold
    at 0 bytes) and without (a threshold no mesh reaches): the same image, bit for bit."""
    from raycast_shade.common import prefetch

    k = prepare(_HALL, _HALL.camera)

    def traced(threshold):
        monkeypatch.setattr(prefetch, "PREFETCH_BYTES", threshold)  # read by prefetch.beyond_caches
        return trace_mirrors(_HALL, _HALL.camera, _HITS, _LOCAL.copy(), depth, k)

    with_hint, without = traced(0), traced(1 << 62)
    assert not np.array_equal(with_hint, _LOCAL)  # the bounces changed the image
    assert np.array_equal(with_hint.view(np.uint32), without.view(np.uint32))


@pytest.mark.parametrize("depth", [1, 3])
@pytest.mark.parametrize("projection", ["perspective", "orthographic"])
@pytest.mark.parametrize("threshold", [0, 1 << 62])
def test_lanes_started_in_groups_are_the_pixel_by_pixel_lanes(depth, projection, threshold, monkeypatch):
    """The hall's lanes started four tiles at a time by the batched Phong passes
    (``mirrors._start_group``) and pixel by pixel (``_start_lane``, what bump-mapped frames take),
    prefetching or not, under both projections: the same image, bit for bit."""
    from dataclasses import replace

    from raycast_shade.common import prefetch
    from raycast_shade.shading import mirrors

    cam = _HALL.camera if projection == "perspective" else replace(_HALL.camera, projection="orthographic",
                                                                    ortho_height=3.0)
    hall = _HALL.replace(camera=cam)
    hits = rs.cast_camera(hall.geometry, cam)
    local = rs.shade(hall, cam, hits)
    k = prepare(hall, cam)
    monkeypatch.setattr(prefetch, "PREFETCH_BYTES", threshold)
    assert mirrors._batched_start(k["B"])

    def traced(batched):
        monkeypatch.setattr(mirrors, "_batched_start", lambda B: batched)
        return trace_mirrors(hall, cam, hits, local.copy(), depth, k)

    grouped, single = traced(True), traced(False)
    assert not np.array_equal(grouped, local)  # the bounces changed the image
    assert np.array_equal(grouped.view(np.uint32), single.view(np.uint32))


def test_each_start_of_the_lanes_is_a_build_of_its_own(monkeypatch):
    """How the lanes start, and whether the gathers ahead are prefetched, are compile-time
    constants of the kernel (closure values, as the variant flags): a frame runs, so compiles,
    only the build of the start it takes (the batched start; else rays handed over by the Phong
    kernel or pixel by pixel, one build; the demo's frames compile no ``_start_group``), and
    prefetches only on a mesh beyond the caches, never with rays handed over (the demo's and
    the lecture's meshes compile no prefetching)."""
    import inspect

    from raycast_shade.common import prefetch
    from raycast_shade.shading import mirrors
    from raycast_shade.shading.mirror_rays import hand_over_buffers

    builds = {"_PACKETS": (False, False), "_PACKETS_BATCHED": (True, False), "_PACKETS_AHEAD": (False, True),
              "_PACKETS_BATCHED_AHEAD": (True, True)}
    for name, (batched, ahead) in builds.items():
        registry = getattr(mirrors, name)
        assert len(registry) == 2  # textured or not
        for fn in registry.values():
            closure = inspect.getclosurevars(fn.py_func).nonlocals
            assert (closure["batched"], closure["ahead"]) == (batched, ahead)
    seen = []
    for name in builds:
        monkeypatch.setattr(mirrors, name, {key: lambda *a, n=name: seen.append(n) for key in getattr(mirrors, name)})
    k = prepare(_HALL, _HALL.camera)
    for threshold in (1 << 62, 0):  # the hall is below the caches, or (0) beyond
        monkeypatch.setattr(prefetch, "PREFETCH_BYTES", threshold)
        for batched in (True, False):
            monkeypatch.setattr(mirrors, "_batched_start", lambda B, b=batched: b)
            trace_mirrors(_HALL, _HALL.camera, _HITS, _LOCAL.copy(), 2, k)
        monkeypatch.setattr(mirrors, "_batched_start", lambda B: True)
        rays = hand_over_buffers(*_HITS.shape)
        trace_mirrors(_HALL, _HALL.camera, _HITS, _LOCAL.copy(), 2, k, rays=rays)
    # handed rays: never the batched start, never prefetching
    assert seen == ["_PACKETS_BATCHED", "_PACKETS", "_PACKETS",
                    "_PACKETS_BATCHED_AHEAD", "_PACKETS_AHEAD", "_PACKETS"]
