"""The lecture's formula with one pixel's numbers filled in: ``str(explain(frame, x, y))``.

Lines stay under about 100 characters, for a projector. An RGB value whose
channels agree (a grey ``kd``, a white light's ``Ii``) prints as one number,
as it was given; a geometric vector (``p``, ``n``, ``v``, ``s``, ``r``, ``h``, a
light's position, the barycentrics) always prints its three components, so
``s = (0.5774, 0.5774, 0.5774)`` never reads as a scalar.

Every step prints its result to 4 significant digits, and its operands with
as many digits as it takes (4 or more) for the printed operands to give the
printed result again at 4 digits: a student who redoes ``r.v = 0.99979``
raised to ``t = 40`` by hand gets the printed ``0.9916``, not a result 0.0007
off because ``r.v`` was printed as ``0.9998``. So one quantity may print
with more digits where a later step uses it than on its own line.

The names are the fields' names: the lecture's ``Ia``, ``Ii``, ``Ks`` and
``t`` are spelled out once (``scene.ambient``, ``light.intensity x
light.color``, ``material.ks``, ``material.shininess``). A pixel above 1 in a
channel is said to show clipped in the 8-bit picture.
"""

from __future__ import annotations

import numpy as np

__all__ = ["format_explanation", "fmt", "vec"]

_FORMULA = {
    "phong": "I = Ia ka + sum_i att_i Ii (kd (n.s_i) + Ks (r_i.v)^t),  r_i = 2 (n.s_i) n - s_i",
    "blinn": "I = Ia ka + sum_i att_i Ii (kd (n.s_i) + Ks (n.h_i)^t),  h_i = (s_i + v) / |s_i + v|",
}
_LEGEND = "  (Ia = scene.ambient, Ii = light intensity x color, Ks = material.ks, t = material.shininess)"
_LAW = {"none": "no attenuation, att = 1", "inverse_square": "inverse square, att = 1/d^2",
        "heuristic": "heuristic, att = 1/(d + k)"}


def fmt(x, digits: int = 4) -> str:
    """A number, or an RGB triple as one number when its channels agree, to ``digits`` significant digits."""
    a = np.atleast_1d(np.asarray(x, np.float64))
    if a.size == 1 or np.all(a == a[0]):
        return f"{a[0]:.{digits}g}"
    return "(" + ", ".join(f"{c:.{digits}g}" for c in a) + ")"


def vec(x, digits: int = 4) -> str:
    """A geometric vector (any length), every component printed to ``digits`` significant digits."""
    a = np.atleast_1d(np.asarray(x, np.float64))
    return "(" + ", ".join(f"{c:.{digits}g}" for c in a) + ")"


def _printed(x, digits: int) -> np.ndarray:
    """The value a reader takes from ``fmt(x, digits)``: each channel rounded to ``digits`` significant digits."""
    return np.array([float(f"{c:.{digits}g}") for c in np.atleast_1d(np.asarray(x, np.float64))])


MAX_DIGITS = 9


def digits_for(operands, compute, result) -> int:
    """The fewest significant digits (4 to :data:`MAX_DIGITS`) at which the printed
    ``operands`` give, through ``compute``, the printed (4-digit) ``result``.

    Parameters
    ----------
    operands : sequence of float or (3,) float
    compute : callable
        ``compute(*operands)``, on the operands as printed, in float64.
    result : float or (3,) float
        The step's result as computed, printed to 4 digits.

    Returns
    -------
    int
        :data:`MAX_DIGITS` if no precision up to it recomputes the result (the
        result then holds a factor the line does not print).
    """
    target = fmt(result)
    for d in range(4, MAX_DIGITS):
        if fmt(compute(*(_printed(o, d) for o in operands))) == target:
            return d
    return MAX_DIGITS


def _product(*xs):
    out = np.ones(1)
    for x in xs:
        out = out * x
    return out


def _step(operands, compute, result, sep) -> str:
    """``a sep b sep c = result``, the operands to :func:`digits_for`'s precision
    (``sep`` a string, or one per gap)."""
    d = digits_for(operands, compute, result)
    seps = [sep] * (len(operands) - 1) if isinstance(sep, str) else list(sep)
    text = fmt(operands[0], d) + "".join(g + fmt(o, d) for g, o in zip(seps, operands[1:]))
    return f"{text} = {fmt(result)}"


def _light_lines(t, kd, ks, indent: str) -> list:
    """One light's arithmetic at one point."""
    if t.directional:
        head = f"light {t.index}, directional: s = {vec(t.s)}, att = 1, Ii = {fmt(t.radiance)}"
    elif t.s is None:
        return [f"{indent}light {t.index}, point: on the surface point itself (d = 0): no direction, no light"]
    else:
        law = _LAW[t.law] + (f", k = {t.k:.4g}" if t.law == "heuristic" else "")
        what = "point" if t.samples == 1 else f"area sample {t.sample + 1} of {t.samples} (1/{t.samples} in att)"
        head = f"light {t.index}, {what} at {vec(t.position)}, {law}: d = {t.d:.4g}, att = {t.att:.4g}"
    lines = [indent + head]
    if t.directional is False:
        lines.append(f"{indent}  Ii = {fmt(t.radiance)}, s = {vec(t.s)}")
    if t.spot is not None:
        if t.spot == 0.0:
            lines.append(f"{indent}  spot: outside the outer cone, no light (no shadow ray)")
            return lines
        lines.append(f"{indent}  spot: cone factor cos^n(a) smoothstep = {t.spot:.4g}, included in att")
    if t.ndots <= 0.0:
        lines.append(f"{indent}  n.s = {t.ndots:.4g} <= 0: the surface faces away, no light (no shadow ray)")
        return lines
    shadow = {"lit": "shadow ray: lit", "blocked": "shadow ray: BLOCKED, in shadow: no light",
              "no shadows": "(this light casts no shadows)"}[t.shadow]
    lines.append(f"{indent}  n.s = {t.ndots:.4g}, {shadow}")
    if t.shadow == "blocked":
        return lines
    ns = min(t.ndots, 1.0)
    lines.append(f"{indent}  diffuse  att Ii kd (n.s) = "
                 + _step((t.att, t.radiance, kd, ns), _product, t.diffuse, " x "))
    if t.cos is not None:
        power = _power(t.shininess)
        d = digits_for((t.cos,), power, t.spec)
        if t.specular_model == "blinn":
            lines.append(f"{indent}  h = (s + v) / |s + v| = {vec(t.rh)}, n.h = {fmt(t.cos, d)}, "
                         f"(n.h)^t = {fmt(t.spec)}")
        else:
            lines.append(f"{indent}  r = 2 (n.s) n - s = {vec(t.rh)}, r.v = {fmt(t.cos, d)}, "
                         f"(r.v)^t = {fmt(t.spec)}")
        lines.append(f"{indent}  specular att Ii Ks (.)^t = "
                     + _step((t.att, t.radiance, ks, t.spec), _product, t.specular, " x "))
    return lines


def _power(shininess):
    """``(.)^t`` as the kernels take it: the cosine clamped to [0, 1], then raised."""
    return lambda c: np.clip(c, 0.0, 1.0) ** shininess


def _shade_lines(s, indent: str = "  ") -> list:
    """One evaluation of the equation."""
    where = f"the {s.where}" if s.where in ("pixel", "face centre") else s.where
    towards = "towards the eye" if not s.where.startswith("bounce") else "back along the ray"
    lines = [f"{indent}at {where}: p = {vec(s.p)}",
             f"{indent}  n = {vec(s.n)}" + (f"\n{indent}    ({s.normal_note})" if s.normal_note else ""),
             f"{indent}  v = {vec(s.v)}  ({towards})",
             f"{indent}  ka = {fmt(s.ka)}, kd = {fmt(s.kd)}, ks = {fmt(s.ks)}, shininess t = {s.shininess:.6g}"
             + (f"\n{indent}    ({s.coef_note})" if s.coef_note else ""),
             f"{indent}  ambient  Ia ka = " + _step((s.ia, s.ka), _product, s.ambient, " x ")]
    for t in s.lights:
        lines += _light_lines(_with_shininess(t, s.shininess), s.kd, s.ks, indent + "  ")
    if np.any(s.ke != 0.0):  # the emission term, added last
        lines.append(f"{indent}  emissive ke = {fmt(s.ke)}")
        d = digits_for((s.ambient, s.diffuse, s.specular, s.ke), lambda a, b, c, e: a + b + c + e, s.total)
        lines.append(f"{indent}  I = ambient + diffuse + specular + emissive = {fmt(s.ambient, d)} + "
                     f"{fmt(s.diffuse, d)} + {fmt(s.specular, d)} + {fmt(s.ke, d)}")
    else:
        d = digits_for((s.ambient, s.diffuse, s.specular), lambda a, b, c: a + b + c, s.total)
        lines.append(f"{indent}  I = ambient + diffuse + specular = {fmt(s.ambient, d)} + {fmt(s.diffuse, d)} + "
                     f"{fmt(s.specular, d)}")
    lines.append(f"{indent}    = {fmt(s.total)}")
    return lines


class _with_shininess:
    """A light term that also knows the material's ``t`` (for the ``(r.v)^t`` step)."""

    def __init__(self, term, shininess):
        self._term, self.shininess = term, float(shininess)

    def __getattr__(self, name):
        return getattr(self._term, name)


def format_explanation(e) -> str:
    """The text of an :class:`~raycast_shade.insight.explain.Explanation`."""
    if e.method is None:
        return (f"pixel ({e.x}, {e.y}): background, nothing hit: I = {fmt(e.total)}\n"
                f"frame.image[{e.y}, {e.x}] = {fmt(e.image)}")
    name = f" '{e.model_name}'" if e.model_name else ""
    model = e.shades[0].lights[0].specular_model if e.shades and e.shades[0].lights else "phong"
    lines = [f"pixel ({e.x}, {e.y}): {e.method.capitalize()} shading of model {e.model}{name}, "
             f"triangle {e.triangle}",
             f"  vertices {', '.join(map(str, e.vertex_ids))}, barycentrics {vec(e.barycentrics)}",
             _FORMULA[model].replace("^t),", "^t) + ke,") if np.any(e.emissive != 0.0) else _FORMULA[model],
             _LEGEND + ("\n  (ke = material.ke: emission, added whatever the lights)" if np.any(e.emissive != 0.0)
                        else "")]
    where = {"flat": "once per triangle, at its centre, with the face's normal",
             "gouraud": "at the three vertices, then the shades interpolated",
             "phong": "at the pixel's point, with the normal interpolated"}[e.method]
    lines.append(f"{e.method.capitalize()}: the equation is evaluated {where}")
    for s in e.shades:
        lines += _shade_lines(s)
    if e.method == "gouraud":
        totals = [s.total for s in e.shades]
        n = len(totals)
        d = digits_for(tuple(e.weights) + tuple(totals), lambda *a: sum(a[i] * a[n + i] for i in range(n)),
                       e.local)
        names = " + ".join(f"w_{s.where.split()[-1]} I_{s.where.split()[-1]}" for s in e.shades)
        parts = " + ".join(f"{fmt(w, d)} x {fmt(i, d)}" for w, i in zip(e.weights, totals))
        lines.append(f"  I = {names}")
        lines.append(f"    = {parts} = {fmt(e.local)}")
        lines.append(f"    (ambient {fmt(e.ambient)}, diffuse {fmt(e.diffuse)}, specular {fmt(e.specular)}"
                     + (f", emissive {fmt(e.emissive)})" if np.any(e.emissive != 0.0) else ")"))
    if e.bounces:
        lines.append(f"mirror: I = (1 - rho) I_local + sum_j w_j c_j, rho = {e.rho:.4g}")
        for b in e.bounces:
            if b.shade is None:
                lines.append(f"  bounce {b.depth}: the ray {vec(b.direction)} misses: c = background {fmt(b.colour)}, "
                             f"w = {b.weight:.4g}")
                continue
            lines.append(f"  bounce {b.depth}: the ray {vec(b.direction)} hits model {b.model}, triangle "
                         f"{b.triangle}; w = {b.weight:.4g}, c = {b.keep:.4g} x I = {fmt(b.colour)}")
            lines += _shade_lines(b.shade, "    ")
        lines.append("  I = " + _step((1.0 - e.rho, e.local, e.reflected), lambda k, a, b: k * a + b, e.total,
                                      (" x ", " + ")))
    lines.append(f"total I = {fmt(e.total)};  frame.image[{e.y}, {e.x}] = {fmt(e.image)}")
    lines += _clipping(e.image)
    return "\n".join(lines)


def _clipping(image) -> list:
    """A line saying that a channel above 1 shows clipped, when one is."""
    a = np.atleast_1d(np.asarray(image, np.float64))
    over = [name for name, c in zip("RGB", a) if c > 1.0] if a.size == 3 else (["I"] if a[0] > 1.0 else [])
    if not over:
        return []
    return [f"  {'/'.join(over)} above 1: shown clipped to 1 (255) in the 8-bit picture (tonemap='clamp');",
            "  frame.show(exposure=0.5) or frame.show(tonemap='reinhard') shows what is above"]
