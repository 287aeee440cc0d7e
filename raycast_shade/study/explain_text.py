"""The lecture's formula with one pixel's numbers filled in: ``str(explain(frame, x, y))``.

Lines stay under about 100 characters, for a projector; an RGB value whose
channels agree prints as one number.
"""

from __future__ import annotations

import numpy as np

__all__ = ["format_explanation", "fmt"]

_FORMULA = {
    "phong": "I = Ia ka + sum_i att_i Ii (kd (n.s_i) + Ks (r_i.v)^t),  r_i = 2 (n.s_i) n - s_i",
    "blinn": "I = Ia ka + sum_i att_i Ii (kd (n.s_i) + Ks (n.h_i)^t),  h_i = (s_i + v) / |s_i + v|",
}
_LAW = {"none": "no attenuation, att = 1", "inverse_square": "inverse square, att = 1/d^2",
        "heuristic": "heuristic, att = 1/(d + k)"}


def fmt(x) -> str:
    """A number, or an RGB triple as one number when its channels agree, to 4 significant digits."""
    a = np.atleast_1d(np.asarray(x, np.float64))
    if a.size == 1 or np.all(a == a[0]):
        return f"{a[0]:.4g}"
    return "(" + ", ".join(f"{c:.4g}" for c in a) + ")"


def _light_lines(t, kd, ks, indent: str) -> list:
    """One light's arithmetic at one point."""
    if t.directional:
        head = f"light {t.index}, directional: s = {fmt(t.s)}, att = 1, Ii = {fmt(t.radiance)}"
    elif t.s is None:
        return [f"{indent}light {t.index}, point: on the surface point itself (d = 0): no direction, no light"]
    else:
        law = _LAW[t.law] + (f", k = {t.k:.4g}" if t.law == "heuristic" else "")
        head = f"light {t.index}, point at {fmt(t.position)}, {law}: d = {t.d:.4g}, att = {t.att:.4g}"
    lines = [indent + head]
    if t.directional is False:
        lines.append(f"{indent}  Ii = {fmt(t.radiance)}, s = {fmt(t.s)}")
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
    lines.append(f"{indent}  diffuse  att Ii kd (n.s) = {t.att:.4g} x {fmt(t.radiance)} x {fmt(kd)} x {ns:.4g} "
                 f"= {fmt(t.diffuse)}")
    if t.cos is not None:
        if t.specular_model == "blinn":
            lines.append(f"{indent}  h = (s + v) / |s + v| = {fmt(t.rh)}, n.h = {t.cos:.4g}, "
                         f"(n.h)^t = {t.spec:.4g}")
        else:
            lines.append(f"{indent}  r = 2 (n.s) n - s = {fmt(t.rh)}, r.v = {t.cos:.4g}, (r.v)^t = {t.spec:.4g}")
        lines.append(f"{indent}  specular att Ii Ks (.)^t = {t.att:.4g} x {fmt(t.radiance)} x {fmt(ks)} x {t.spec:.4g} "
                     f"= {fmt(t.specular)}")
    return lines


def _shade_lines(s, indent: str = "  ") -> list:
    """One evaluation of the equation."""
    where = f"the {s.where}" if s.where in ("pixel", "face centre") else s.where
    towards = "towards the eye" if not s.where.startswith("bounce") else "back along the ray"
    lines = [f"{indent}at {where}: p = {fmt(s.p)}",
             f"{indent}  n = {fmt(s.n)}" + (f"\n{indent}    ({s.normal_note})" if s.normal_note else ""),
             f"{indent}  v = {fmt(s.v)}  ({towards})",
             f"{indent}  ka = {fmt(s.ka)}, kd = {fmt(s.kd)}, Ks = {fmt(s.ks)}, t = {s.shininess:.4g}"
             + (f"\n{indent}    ({s.coef_note})" if s.coef_note else ""),
             f"{indent}  ambient  Ia ka = {fmt(s.ia)} x {fmt(s.ka)} = {fmt(s.ambient)}"]
    for t in s.lights:
        lines += _light_lines(t, s.kd, s.ks, indent + "  ")
    lines.append(f"{indent}  I = ambient + diffuse + specular = {fmt(s.ambient)} + {fmt(s.diffuse)} + "
                 f"{fmt(s.specular)}")
    lines.append(f"{indent}    = {fmt(s.total)}")
    return lines


def format_explanation(e) -> str:
    """The text of an :class:`~raycast_shade.study.explain.Explanation`."""
    if e.method is None:
        return (f"pixel ({e.x}, {e.y}): background, nothing hit: I = {fmt(e.total)}\n"
                f"frame.image[{e.y}, {e.x}] = {fmt(e.image)}")
    name = f" '{e.model_name}'" if e.model_name else ""
    model = e.shades[0].lights[0].specular_model if e.shades and e.shades[0].lights else "phong"
    lines = [f"pixel ({e.x}, {e.y}): {e.method.capitalize()} shading of model {e.model}{name}, "
             f"triangle {e.triangle}",
             f"  vertices {', '.join(map(str, e.vertex_ids))}, barycentrics {fmt(e.barycentrics)}",
             _FORMULA[model]]
    where = {"flat": "once per triangle, at its centre, with the face's normal",
             "gouraud": "at the three vertices, then the shades interpolated",
             "phong": "at the pixel's point, with the normal interpolated"}[e.method]
    lines.append(f"{e.method.capitalize()}: the equation is evaluated {where}")
    for s in e.shades:
        lines += _shade_lines(s)
    if e.method == "gouraud":
        parts = " + ".join(f"{w:.4g} I_{s.where.split()[-1]}" for w, s in zip(e.weights, e.shades))
        lines.append(f"  I = {parts} = {fmt(e.local)}")
        lines.append(f"    (ambient {fmt(e.ambient)}, diffuse {fmt(e.diffuse)}, specular {fmt(e.specular)})")
    if e.bounces:
        lines.append(f"mirror: I = (1 - rho) I_local + sum_j w_j c_j, rho = {e.rho:.4g}")
        for b in e.bounces:
            if b.shade is None:
                lines.append(f"  bounce {b.depth}: the ray {fmt(b.direction)} misses: c = background {fmt(b.colour)}, "
                             f"w = {b.weight:.4g}")
                continue
            lines.append(f"  bounce {b.depth}: the ray {fmt(b.direction)} hits model {b.model}, triangle "
                         f"{b.triangle}; w = {b.weight:.4g}, c = {b.keep:.4g} x I = {fmt(b.colour)}")
            lines += _shade_lines(b.shade, "    ")
        lines.append(f"  I = {1.0 - e.rho:.4g} x {fmt(e.local)} + {fmt(e.reflected)} = {fmt(e.total)}")
    lines.append(f"total I = {fmt(e.total)};  frame.image[{e.y}, {e.x}] = {fmt(e.image)}")
    return "\n".join(lines)
