"""raycast_shade.gradients_jax: a frame inside a JAX model (issue 43, item 3).

``jax.grad`` through :func:`render_fn` is ``rs.grad`` of the same frame (the cotangent is the
float32 image's, so ``rs.grad`` is given the same float32-rounded ``dL/dI``); a few hand-written
Adam and SGD steps in JAX lower a loss; ``params_of`` / ``with_params`` round-trip; bad input is
refused naming the field; ``import raycast_shade`` does not import JAX, and without JAX the
function names the extra.
"""

from __future__ import annotations

import pathlib
import subprocess
import sys

import numpy as np
import pytest

import raycast_shade as rs
from raycast_shade.common.extras import MissingExtraError
from raycast_shade.gradients_jax import JAX_DEFAULT, params_of, render_fn, with_params

jax = pytest.importorskip("jax", reason="the [jax] extra (CI installs it with [test])")
jnp = jax.numpy

H, W = 24, 32


def _scene(**mat):
    material = rs.Material(**{"kd": (0.6, 0.4, 0.3), "ka": (0.5, 0.6, 0.7), "ks": (0.5, 0.4, 0.6),
                              "shininess": 20.0, **mat})
    lights = [rs.PointLight((2.0, 3.0, 4.0), intensity=20.0, attenuation="inverse_square"),
              rs.DirectionalLight((-1.0, -0.5, -1.0), intensity=0.5, color=(1.0, 0.8, 0.6)),
              rs.PointLight((-3.0, 1.0, 2.0), intensity=4.0, attenuation="heuristic", k=1.5)]
    return rs.Scene([rs.Model(rs.shapes.icosphere(2), material)], lights=lights,
                    camera=rs.Camera(eye=(0.0, 0.0, 4.0), width=W, height=H), ambient=(0.1, 0.12, 0.08))


def _jnp(values):
    return {k: jnp.asarray(v) for k, v in values.items()}


@pytest.mark.parametrize("shading, names", [
    ("phong", ("kd", "ks", "shininess", "ambient", "light_position", "light_direction", "light_k")),
    ("phong", ("ka", "light_radiance")),
    ("gouraud", ("kd", "shininess", "light_intensity", "light_position")),
    ("flat", ("ks", "light_direction", "ambient")),
])
def test_jax_grad_is_rs_grad(shading, names):
    scene = _scene(specular="blinn") if shading == "gouraud" else _scene()
    weights = np.random.default_rng(7).normal(size=(H, W, 3))
    f = render_fn(scene, names, shading=shading)
    params = _jnp(params_of(scene, names))
    image = f(params)
    np.testing.assert_allclose(np.asarray(image), rs.render(scene, shading).image, rtol=1e-5, atol=1e-6)
    # JAX's default float32 rounds the values: the frame is that of the rounded values.
    scene = with_params(scene, {k: np.asarray(v, np.float64) for k, v in params.items()})
    frame = rs.render(scene, shading)
    np.testing.assert_array_equal(np.asarray(image), frame.image)  # the same frame, bit for bit
    got = jax.grad(lambda p: jnp.sum(f(p) * weights))(params)
    # The cotangent of a float32 image is float32: rs.grad given the same rounded dL/dI.
    want = rs.grad(scene, weights.astype(np.float32).astype(np.float64), names, shading=shading, frame=frame)
    for name in names:
        assert got[name].shape == want[name].shape, name
        scale = max(float(np.max(np.abs(want[name]))), 1e-12)
        np.testing.assert_allclose(np.asarray(got[name]), want[name], rtol=0, atol=1e-6 * scale, err_msg=name)
        assert np.any(want[name] != 0), name  # each family has something to compare


def test_jit_and_non_unit_direction():
    """Under jax.jit the same gradient; a direction given at twice its length: the chain rule's 1/2."""
    scene = _scene()
    weights = np.random.default_rng(3).normal(size=(H, W, 3))
    f = render_fn(scene, ("light_direction", "kd"))
    p = _jnp(params_of(scene, ("light_direction", "kd")))
    loss = lambda q: jnp.sum(f(q) * weights)  # noqa: E731
    g = jax.grad(loss)(p)
    gj = jax.jit(jax.grad(loss))(p)
    np.testing.assert_array_equal(np.asarray(gj["kd"]), np.asarray(g["kd"]))
    p2 = dict(p, light_direction=2.0 * p["light_direction"])
    np.testing.assert_array_equal(np.asarray(f(p2)), np.asarray(f(p)))
    g2 = jax.grad(loss)(p2)
    np.testing.assert_allclose(np.asarray(g2["light_direction"]), 0.5 * np.asarray(g["light_direction"]),
                               rtol=1e-6, atol=1e-9)


def _descend(step, n=8):
    """``n`` steps of ``step`` on kd and the first light's position from a wrong start; the losses."""
    target_scene = _scene()
    target = jnp.asarray(rs.render(target_scene, "phong").image)
    names = ("kd", "light_position")
    start = params_of(target_scene, names)
    start["kd"] = np.full_like(start["kd"], 0.3)
    start["light_position"] = start["light_position"] + np.array([[0.8, -0.6, 0.5], [0, 0, 0], [0, 0, 0]])
    f = render_fn(target_scene, names)
    loss = jax.value_and_grad(lambda p: jnp.mean((f(p) - target) ** 2))
    p, state, losses = _jnp(start), None, []
    for i in range(n):
        value, g = loss(p)
        losses.append(float(value))
        p, state = step(p, g, state, i)
    losses.append(float(loss(p)[0]))
    return losses


def _adam(p, g, state, i, lr=0.05, b1=0.9, b2=0.999, eps=1e-8):
    m, v = state or ({k: jnp.zeros_like(x) for k, x in p.items()}, {k: jnp.zeros_like(x) for k, x in p.items()})
    m = {k: b1 * m[k] + (1 - b1) * g[k] for k in p}
    v = {k: b2 * v[k] + (1 - b2) * g[k] ** 2 for k in p}
    t = i + 1
    p = {k: p[k] - lr * (m[k] / (1 - b1 ** t)) / (jnp.sqrt(v[k] / (1 - b2 ** t)) + eps) for k in p}
    return p, (m, v)


def test_adam_steps_lower_the_loss():
    losses = _descend(_adam)
    assert losses[-1] < 0.5 * losses[0], losses
    assert all(np.isfinite(losses))


def test_sgd_steps_lower_the_loss():
    def sgd(p, g, state, i):  # per-block normalised steps: the blocks' gradients differ by orders
        return {k: p[k] - 0.05 * g[k] / (jnp.linalg.norm(g[k]) + 1e-12) for k in p}, None

    losses = _descend(sgd, n=6)
    assert losses[-1] < losses[0], losses
    assert np.all(np.diff(losses[:3]) < 0), losses


def test_params_round_trip_and_defaults():
    scene = _scene()
    values = params_of(scene)
    assert tuple(values) == JAX_DEFAULT and "light_intensity" not in values
    assert values["light_position"].shape == (3, 3) and np.all(values["light_position"][1] == 0)
    assert values["light_k"][2] == 1.5 and values["light_k"][1] == 0
    again = with_params(scene, values)
    assert again.geometry is not None
    np.testing.assert_array_equal(rs.render(again, "phong").image, rs.render(scene, "phong").image)
    moved = with_params(scene, {"kd": np.array([[0.1, 0.2, 0.3]])})
    assert tuple(moved.models[0].material.kd) == (0.1, 0.2, 0.3)
    assert moved.geometry.vertices is scene.geometry.vertices  # no repacking


@pytest.mark.parametrize("call, field", [
    (lambda s: render_fn(None, "kd"), "scene"),
    (lambda s: render_fn(s, ("kd", "colour")), "wrt"),
    (lambda s: render_fn(s, "normals"), "wrt"),
    (lambda s: render_fn(s, ("light_radiance", "light_intensity")), "wrt"),
    (lambda s: render_fn(s, "kd", shading="auto"), "shading"),
    (lambda s: render_fn(s, "kd", shading="toon"), "shading"),
    (lambda s: render_fn(s, "kd")({"ks": np.zeros((1, 3))}), "params"),
    (lambda s: render_fn(s, "kd")({"kd": np.zeros(3)}), "params['kd']"),
    (lambda s: with_params(s, {"kd": np.full((1, 3), np.nan)}), "values['kd']"),
    (lambda s: with_params(s, {"albedo": np.zeros((1, 3))}), "values"),
    (lambda s: with_params(s, [1, 2]), "values"),
    (lambda s: params_of(s, "albedo"), "wrt"),
])
def test_bad_input_names_the_field(call, field):
    with pytest.raises((ValueError, TypeError), match=field.replace("[", r"\[").replace("]", r"\]")):
        call(_scene())


def test_without_jax_the_error_names_the_extra(monkeypatch):
    monkeypatch.setitem(sys.modules, "jax", None)  # import jax now raises ImportError
    with pytest.raises(MissingExtraError, match=r"raycast_shade\[jax\]"):
        render_fn(_scene(), "kd")


def test_importing_the_package_does_not_import_jax():
    code = ("import sys, raycast_shade, raycast_shade.gradients_jax; "
            "assert 'jax' not in sys.modules, 'jax imported'; print('ok')")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300,
                         cwd=pathlib.Path(rs.__file__).resolve().parents[1])  # this checkout first on the path
    assert out.returncode == 0 and out.stdout.strip() == "ok", out.stderr[-2000:]


def test_the_generic_bad_values_are_refused_naming_the_argument():
    """tests/project/test_contract.py's walk over these three functions: every generic bad value of
    every argument is a ValueError or TypeError naming it (only ``wrt=None``, the default, is legal)."""
    from tests.project.test_contract import BAD

    tiny = rs.Scene([rs.Model(rs.shapes.icosphere(1), rs.Material(kd=0.6, ks=0.3))],
                    lights=[rs.PointLight((2.0, 3.0, 4.0))], camera=rs.Camera(eye=(0.0, 0.0, 4.0), width=16, height=12))
    table = {render_fn: dict(scene=tiny, wrt=("kd",), shading="phong"), params_of: dict(scene=tiny, wrt=("kd",)),
             with_params: dict(scene=tiny, values={"kd": np.array([[0.1, 0.2, 0.3]])})}
    accepted, unnamed = [], []
    for fn, base in table.items():
        for arg in base:
            for bad, make in BAD.items():
                try:
                    fn(**dict(base, **{arg: make()}))
                    accepted.append((fn.__name__, arg, bad))
                except (ValueError, TypeError) as exc:
                    if arg not in str(exc):
                        unnamed.append((fn.__name__, arg, bad, str(exc)))
    assert accepted == [("render_fn", "wrt", "None"), ("params_of", "wrt", "None")], accepted
    assert not unnamed, unnamed
    for bad in ("'abc'", "nan", "shape"):  # and inside the dict: the entry named
        with pytest.raises((ValueError, TypeError), match=r"values\['kd'\]"):
            with_params(tiny, {"kd": BAD[bad]()})


def test_vmap_runs_the_frames_one_after_another():
    scene = _scene()
    f = render_fn(scene, "kd")
    kd = jnp.asarray(params_of(scene, "kd")["kd"])
    batch = jnp.stack([kd, 0.5 * kd])
    images = jax.vmap(lambda k: f({"kd": k}))(batch)
    assert images.shape == (2, H, W, 3)
    np.testing.assert_array_equal(np.asarray(images[1]), np.asarray(f({"kd": 0.5 * kd})))
    grads = jax.vmap(jax.grad(lambda k: jnp.sum(f({"kd": k}))))(batch)
    np.testing.assert_array_equal(np.asarray(grads[0]), np.asarray(jax.grad(lambda k: jnp.sum(f({"kd": k})))(kd)))
    with pytest.raises(TypeError, match="forward-mode"):  # a custom_vjp: reverse mode only, as documented
        jax.jvp(lambda k: f({"kd": k}), (kd,), (kd,))
