"""The gradient code written once (issue 43's review): the bump lookups shared with the forward pass,
one bent-normal pass per ``rs.grad`` call, and the plain build of the per-point VJP."""

from __future__ import annotations

import ast
import pathlib

import numpy as np
import pytest

import raycast_shade as rs
from raycast_shade.shading import grad_bump, grad_frame
from raycast_shade.shading.grad_terms import _rich
from raycast_shade.shading.inputs import prepare

from .test_grad_bump import H, W, _scene

SHADING = pathlib.Path(grad_bump.__file__).parent


def _names(path) -> set:
    """Every name a module's source reads (functions, constants, attributes)."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    return {n.id for n in ast.walk(tree) if isinstance(n, ast.Name)} | {
        n.attr for n in ast.walk(tree) if isinstance(n, ast.Attribute)}


def test_the_gradient_reads_the_maps_through_the_forward_passs_own_lookups():
    """grad_bump samples no height or normal map itself: the texel lookups (bilinear heights, the
    packed map rows, the normal map's level 0) are bump.py's and normalmap.py's, shared."""
    used = _names(SHADING / "grad_bump.py")
    assert {"_bump_slopes", "_nmap_sample"} <= used
    lookups = {"_bilinear", "_sample_level", "BUMP_OFFSET", "BUMP_SCALE", "BUMP_TILE_U", "BUMP_TILE_V", "nmap_texels",
               "bump_texels", "vertex_tangents"}
    assert not used & lookups, used & lookups
    for forward, helper in (("bump.py", "_bump_slopes"), ("normalmap.py", "_nmap_sample")):
        assert helper in _names(SHADING / forward)


def _counting(monkeypatch):
    """Count the launches of the bent normal's kernel."""
    calls = []
    real = grad_bump.launch

    def launch(kernel, *args, **kwargs):
        if kernel is grad_bump._perturb_kernel:
            calls.append(kernel)
        return real(kernel, *args, **kwargs)

    monkeypatch.setattr(grad_bump, "launch", launch)
    return calls


def _same(a, b) -> bool:
    if isinstance(a, tuple):
        return len(a) == len(b) and all((x is None and y is None) or np.array_equal(x, y) for x, y in zip(a, b))
    return np.array_equal(a, b)


@pytest.mark.parametrize("bump,nmap", [(True, False), (True, True)])
def test_one_bent_normal_pass_serves_the_maps_and_the_normals(monkeypatch, bump, nmap):
    scene = _scene(bump, nmap)
    frame = rs.render(scene, "phong")
    gimg = np.random.default_rng(5).standard_normal((H, W, 3))
    names = ("kd", "normals", "bump_map") + (("normal_map",) if nmap else ())
    calls = _counting(monkeypatch)
    shared = rs.grad(scene, gimg, names, frame=frame)
    assert len(calls) == 1
    assert grad_bump._SHARED.get() is None  # nothing kept after the call
    unshared = rs.grad.__wrapped__(scene, gimg, names, frame=frame)  # each caller its own pass, as before
    assert len(calls) == 3
    for name in names:
        assert _same(shared[name], unshared[name]), name
    assert np.any(shared["normals"] != 0.0) and np.any(shared["bump_map"][0] != 0.0)


def test_a_bent_normal_pass_is_not_reused_for_another_cotangent(monkeypatch):
    """Within one call the pass is keyed on its inputs: another dL/dI runs a pass of its own."""
    scene = _scene(True, False)
    frame = rs.render(scene, "phong")
    inputs, modes = frame.inputs, rs.gradients.resolve_methods(scene, "phong")
    calls = _counting(monkeypatch)
    g1 = np.random.default_rng(6).standard_normal((H, W, 3))
    g2 = 2.0 * g1

    @grad_bump.one_bent_pass
    def two():
        return (grad_bump.perturb_partials(frame.hits, inputs, modes, g1),
                grad_bump.perturb_partials(frame.hits, inputs, modes, g1),
                grad_bump.perturb_partials(frame.hits, inputs, modes, g2))

    a, b, c = two()
    assert len(calls) == 2
    assert a is b
    assert np.array_equal(c[:, 2:4], 2.0 * a[:, 2:4]) and np.any(a[:, 2:4] != 0.0)


def _rows(scene):
    inputs = prepare(scene, scene.camera)
    return inputs.materials, inputs.lighting.lights


def _plain_scene(material=None, lights=None):
    return rs.Scene([rs.Model(rs.shapes.icosphere(1), material or rs.Material(kd=0.5, ks=0.3))],
                    lights=lights or [rs.PointLight((1.0, 2.0, 3.0)), rs.DirectionalLight((0.0, -1.0, 0.0))],
                    camera=rs.Camera(eye=(0.0, 0.0, 4.0), width=16, height=12))


@pytest.mark.parametrize("case,rich", [
    ("plain", False), ("blinn", False), ("spot", False),
    ("ggx", True), ("rectangle", True), ("disc", True)])
def test_the_rich_build_is_asked_for_by_ggx_materials_and_area_lights_only(case, rich):
    material = {"blinn": rs.Material(kd=0.5, ks=0.3, specular="blinn"),
                "ggx": rs.Material(kd=0.5, specular="ggx", metallic=0.2, roughness=0.5)}.get(case)
    lights = {"spot": [rs.SpotLight((0.0, 2.0, 3.0), direction=(0.0, -0.5, -1.0), inner_angle=10.0, outer_angle=20.0)],
              "rectangle": [rs.AreaLight((0.0, 3.0, 0.0), u=(1.0, 0.0, 0.0), v=(0.0, 0.0, 1.0), samples=4)],
              "disc": [rs.AreaLight((0.0, 3.0, 0.0), u=(1.0, 0.0, 0.0), v=(0.0, 0.0, 1.0), samples=4,
                                    shape="disc")]}.get(case)
    assert _rich(*_rows(_plain_scene(material, lights))) is rich


class _Picked(Exception):
    pass


@pytest.mark.parametrize("ggx", [False, True])
def test_frame_vjp_runs_the_plain_build_unless_the_scene_needs_the_rich_one(monkeypatch, ggx):
    """Which of each family's two builds a frame's gradient launches (stopped before it runs: no
    compile here)."""
    material = rs.Material(kd=0.5, specular="ggx", roughness=0.5) if ggx else None
    scene = _plain_scene(material)
    picked = []

    def stop(kernel, *args, **kwargs):
        picked.append(kernel)
        raise _Picked

    monkeypatch.setattr(grad_frame, "launch", stop)
    inputs = prepare(scene, scene.camera)
    modes = rs.gradients.resolve_methods(scene, "phong")
    hits = rs.render(scene, "flat").hits  # any hit buffer of the scene: the kernel is not run
    with pytest.raises(_Picked):
        grad_frame.frame_vjp(hits, inputs, modes, np.ones((12, 16, 3)), scene.geometry)
    assert picked == [grad_frame._PHONG[ggx]]
    assert grad_frame._PHONG[False] is not grad_frame._PHONG[True]
