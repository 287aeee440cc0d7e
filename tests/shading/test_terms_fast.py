"""render(terms=True) through the batched Phong kernel (shading/phong_fast.py): on the scenes it
is dispatched to, its image and terms are the general terms kernel's (terms_kernel.py), bit for bit."""

from __future__ import annotations

import os
import warnings

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import raycast_shade as rs
from raycast_shade.shading.inputs import prepare
from raycast_shade.shading.phong_fast import LANES
from raycast_shade.shading.termshade import TermShading

W, H = 40, 30


def _both(scene, shading, hits, per_light=False):
    """The frame's image and terms by the batched kernel and by the general one, each on
    NaN-filled canvases (a pixel a kernel forgets stays NaN)."""
    k = prepare(scene, scene.camera)
    out = []
    for fast in (True, False):
        ts = TermShading(scene, scene.camera, shading, k, per_light)
        assert ts.fast_phong == (ts.phong and not per_light)  # the scenes below: the dispatch takes it
        ts.fast_phong = fast and ts.fast_phong
        for a in ts.R[:7]:
            if a.size and a.flags.writeable:
                a.fill(np.nan)
        image = ts.shade(hits, out=np.full(hits.shape + (3,), np.nan, np.float32))
        out.append((image, ts.terms()))
    return out


def _same(a, b, name):
    assert a.shape == b.shape and a.dtype == b.dtype, name
    assert np.array_equal(a.view(np.uint32), b.view(np.uint32)), f"{name}: the bits differ"


materials = st.builds(
    lambda kd, ks, t, spec, ke: rs.Material(kd=kd, ks=ks, shininess=t, specular=spec, ke=ke),
    st.tuples(*[st.floats(0.0, 1.0)] * 3), st.sampled_from([0.0, 0.3, (0.0, 0.5, 1.0)]),
    st.one_of(st.integers(1, 300), st.sampled_from([0.5, 37.25, 5000.0])),
    st.sampled_from(["phong", "blinn"]), st.sampled_from([0.0, (0.1, 0.0, 0.2)]))
points = st.tuples(*[st.floats(-3.0, 3.0)] * 3)
lights = st.one_of(
    st.builds(lambda p, i, law: rs.PointLight(p, intensity=i, attenuation=law, k=0.5), points, st.floats(0.1, 20.0),
              st.sampled_from(["none", "inverse_square", "heuristic"])),
    st.builds(lambda d, i: rs.DirectionalLight(d, intensity=i), points.filter(lambda d: np.linalg.norm(d) > 0.1),
              st.floats(0.1, 2.0)),
    st.builds(lambda p, n: rs.SpotLight(p, direction=(-p[0], -p[1], -p[2]), intensity=3.0, exponent=n,
                                        inner_angle=15, outer_angle=35, attenuation="inverse_square"),
              points.filter(lambda p: np.linalg.norm(p) > 0.5), st.sampled_from([0.0, 2.5])))


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(mats=st.lists(materials, min_size=2, max_size=2), lits=st.lists(lights, min_size=1, max_size=3),
       background=st.sampled_from([(0.0, 0.0, 0.0), (0.1, 0.2, 0.3)]),
       methods=st.sampled_from(["phong", ("phong", "flat"), ("gouraud", "phong")]))
def test_the_batched_terms_are_the_general_kernels_bit_for_bit(mats, lits, background, methods):
    """Random materials (both specular models, whole and fractional shininess, emission), every
    light kind and attenuation law, a black or coloured background, Phong alone or beside flat
    and Gouraud models: the image and every term are the same bits, the image the plain
    frame's, and the terms add up to it."""
    cam = rs.Camera(eye=(0.3, 1.0, 3.0), target=(0.0, 0.0, 0.0), width=W, height=H, fov=50)
    models = [rs.Model(rs.shapes.icosphere(2, radius=0.8), mats[0]),
              rs.Model(rs.shapes.plane(4.0, subdivisions=2, center=(0.0, -0.9, 0.0), normal="+y"), mats[1])]
    scene = rs.Scene(models, lights=lits, camera=cam, ambient=(0.1, 0.05, 0.2), background=background)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        plain = rs.render(scene, methods)
    (fast, tf), (general, tg) = _both(scene, methods, plain.hits)
    _same(fast, general, "image")
    _same(fast, plain.image, "image (the plain frame's)")
    assert list(tf) == list(tg)
    for name in tg:
        _same(tf[name], tg[name], name)
    assert not np.isnan(tf["diffuse"]).any() and not np.isnan(tf["ambient"]).any()


def test_full_and_partial_batches_bands_and_per_light():
    """More hits than two batches hold and a last batch part full; the frame in bands (rows at
    ``y0``); per-light terms asked for, which the general kernel writes (the batched one is not
    taken): the same bits each way."""
    cam = rs.Camera(eye=(0.0, 0.0, 1.6), width=3 * LANES + 5, height=9, fov=10)
    scene = rs.Scene([rs.Model(rs.shapes.icosphere(2), rs.Material(ks=0.4, shininess=12, ke=(0.0, 0.1, 0.0)))],
                     lights=[rs.PointLight((1.0, 2.0, 3.0), intensity=9.0, attenuation="inverse_square"),
                             rs.DirectionalLight((0.0, -1.0, -1.0), intensity=0.3)], camera=cam,
                     background=(0.2, 0.2, 0.2))
    hits = rs.render(scene).hits
    assert (hits.prim >= 0).sum() > 2 * LANES and (hits.prim < 0).any()
    (fast, tf), (general, tg) = _both(scene, "phong", hits)
    _same(fast, general, "image")
    for name in tg:
        _same(tf[name], tg[name], name)
    assert (tf["specular"] > 0).any() and (tf["emissive"] > 0).any() and (tf["background"] > 0).any()
    k = prepare(scene, cam)
    ts = TermShading(scene, cam, "phong", k)
    image = np.full((9, cam.width, 3), np.nan, np.float32)
    for y0 in range(0, 9, 4):  # bands of 4 rows: each writes its rows of the frame's terms
        band = rs.HitBuffer(*(np.ascontiguousarray(a[y0:y0 + 4]) for a in (hits.prim, hits.geom, hits.u, hits.v,
                                                                            hits.t)))
        ts.shade(band, out=image[y0:y0 + 4], y0=y0)
    _same(image, general, "banded image")
    for name, a in ts.terms().items():
        _same(a, tg[name], f"banded {name}")
    (_, tp), (_, tq) = _both(scene, "phong", hits, per_light=True)
    for name in tq:
        _same(tp[name], tq[name], f"per-light {name}")


@pytest.mark.parametrize("per_light", [False, True])
def test_render_takes_the_batched_terms_kernel_where_it_applies(per_light, monkeypatch):
    """``render(terms=...)`` shades through the batched kernel when it applies and per-light terms
    are not asked for; shadows (a scene handle) take the general one."""
    from raycast_shade.shading import termshade

    calls = []
    fast = termshade._PHONG_FAST_TERMS
    monkeypatch.setattr(termshade, "_PHONG_FAST_TERMS", lambda *a: (calls.append(1), fast(*a)))
    cam = rs.Camera(eye=(0.0, 0.0, 3.0), width=24, height=16)
    light = rs.PointLight((1.0, 2.0, 3.0), intensity=9.0)
    scene = rs.Scene([rs.Model(rs.shapes.icosphere(1), rs.Material(ks=0.4))], lights=[light], camera=cam)
    rs.render(scene, terms="per_light" if per_light else True)
    assert len(calls) == (0 if per_light else 1)
    calls.clear()
    shadowed = scene.replace(lights=[rs.PointLight((1.0, 2.0, 3.0), intensity=9.0, shadows=True)])
    rs.render(shadowed, terms=True)
    assert not calls


@pytest.mark.skipif(not os.path.exists("/proc/self/smaps"), reason="reads Linux's /proc/self/smaps")
def test_large_untouched_zeros_are_zero_writable_and_ask_for_huge_pages():
    """The term arrays a frame may never write (emissive, background, reflected) are zeros on a
    mapping of their own that asks for transparent huge pages (``hg`` in the mapping's
    ``VmFlags``), so that reading or writing them faults once per 2 MiB; small ones are plain
    ``np.zeros``."""
    from raycast_shade.shading.termshade import _MAPPED_FROM, _untouched_zeros

    big = _untouched_zeros((1080, 1920, 3))
    assert big.nbytes >= _MAPPED_FROM and big.flags.writeable and big.dtype == np.float32
    assert not big.any()
    big[7, 9, 1] = 2.5
    assert big.sum() == 2.5

    addr = big.ctypes.data
    flags = None
    with open("/proc/self/smaps") as fh:
        inside = False
        for line in fh:
            head = line.split()[0]
            if "-" in head and all(c in "0123456789abcdef-" for c in head):
                lo, hi = (int(x, 16) for x in head.split("-"))
                inside = lo <= addr < hi
            elif inside and head == "VmFlags:":
                flags = line.split()[1:]
                break
    assert flags is not None, "the array's mapping is not in /proc/self/smaps"
    assert "hg" in flags

    small = _untouched_zeros((30, 40, 3))
    assert small.nbytes < _MAPPED_FROM and not small.any() and small.flags.writeable
