"""The catalogue of candidate explanations: the lecture's choices and the common slips.

Each :class:`Candidate` is a :class:`~.variant.Mistake` of the variant shader
(so its image comes from our renderer's equation with one switch turned),
named, explained in one sentence, and tied to the slide of the lecture
("Interactive Computer Graphics, Lecture 7: Shading") whose rule it breaks,
by the slide's title. ``docs/diagnose.md`` lists them.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...scene.lights import DirectionalLight, SpotLight
from .variant import Mistake

__all__ = ["Candidate", "catalogue", "ENCODING_CHOICES"]

ENCODING_CHOICES = ("srgb", "linear", "auto")


@dataclass(frozen=True)
class Candidate:
    """One explanation of a student's image.

    Attributes
    ----------
    name : str
        Short identifier, e.g. ``"no-ambient"``.
    text : str
        What the renderer did, in words.
    slide : str
        Title of the lecture slide whose rule it breaks (or follows).
    mistake : Mistake
        The variant shader's configuration.
    correct : bool
        True for the image a correct renderer makes.
    """

    name: str
    text: str
    slide: str
    mistake: Mistake
    correct: bool = False


_OUTPUT = "none: writing the image"  # encoding, row order, pixel centres, channel order: not in the lecture
_METHOD_SLIDES = {"flat": "Flat Shading", "gouraud": "Gouraud Shading", "phong": "Phong Shading"}
_LAW_TEXT = {"none": "no attenuation (Ii reaches every point)", "inverse": "attenuation 1/d",
             "inverse_square": "attenuation 1/d^2", "heuristic": "attenuation 1/(d + k)"}


def _single(method, scene, encoding):
    """The one-slip candidates (name, text, slide, Mistake changes) for the method asked for."""
    out = []
    for other in ("flat", "gouraud", "phong"):
        if other != method:
            out.append((f"{other}-shading", f"{other.capitalize()} shading instead of {method.capitalize()}",
                        _METHOD_SLIDES[other], dict(method=other)))
    if method != "flat":
        out += [
            ("2d-interpolation", "interpolated in 2D (screen-space weights) instead of 3D", "2D or 3D",
             dict(screen=True)),
            ("face-normals", "the face normal at every vertex instead of the averaged vertex normal",
             "Computing an average normal vector at a vertex", dict(normals="face")),
        ]
        out += [(f"{w}-weights", f"vertex normals averaged with {w} weights instead of the mesh's",
                 "Computing an average normal vector at a vertex", dict(normals=w))
                for w in ("uniform", "area", "angle")]
    out += [
        ("no-ambient", "the ambient term Ia ka left out", "Reflectance equation with ambient light",
         dict(no_ambient=True)),
        ("no-diffuse", "the diffuse term Ii kd n.s left out", "Lambert's Cosine Law", dict(no_diffuse=True)),
        ("no-specular", "the specular term Ii Ks (r.v)^t left out", "Modelling specular reflection",
         dict(no_specular=True)),
        ("specular-times-kd", "the specular term multiplied by kd too (a highlight the surface's colour)",
         "Modelling specular reflection", dict(kd_specular=True)),
        ("specular-ungated", "the specular term added where n.s <= 0 too (lit from behind)",
         "Simplifications and Complications", dict(ungated=True)),
        ("n.s-unclamped", "n.s not clamped at 0: negative diffuse light behind the terminator", "Lambert's Cosine Law",
         dict(unclamped=True)),
        ("s-unnormalised", "s = L - p not divided by |s|", "Vector formulation", dict(raw_s=True)),
        ("v-unnormalised", "v = e - p not divided by |v|", "Vector formulation", dict(raw_v=True)),
        ("r-sign", "r = s - 2 (n.s) n (reflected the wrong way)", "Vector formulation", dict(r_sign=True)),
        ("halfway-swapped", "Blinn's halfway vector n.h where Phong's r.v is asked for (or back)",
         "Bui-Tuong Phong formula", dict(specular="swap")),
        ("shininess-times-cos", "shininess applied as t cos(a) instead of cos^t(a)", "Bui-Tuong Phong formula",
         dict(linear_shininess=True)),
    ]
    if method == "phong":
        out += [
            ("n-unnormalised", "the interpolated normal a used without dividing by |a|",
             "Interpolation of the 3D normals", dict(raw_n=True)),
            ("r-unnormalised-n", "r = 2 (n.s) n - s with the interpolated n before normalisation",
             "Vector formulation", dict(raw_n_in_r=True)),
        ]
    points = [light for light in scene.lights if not isinstance(light, DirectionalLight)]
    laws = {light.attenuation for light in points}
    for law in ("none", "inverse", "inverse_square", "heuristic"):
        if points and laws != {law}:
            slide = "Heuristic Law" if law == "heuristic" else "Inverse Square Law"
            out.append((f"attenuation-{law}", _LAW_TEXT[law] + " instead of the scene's law", slide, dict(law=law)))
    if laws - {"none"}:
        out.append(("distance-from-eye", "attenuation distance measured from the viewpoint, not the light",
                    "Distance to the viewpoint", dict(eye_distance=True)))
    if scene.lights:
        out.append(("light-in-camera-space", "light positions read as camera coordinates, not world ones",
                    "Vector Notation", dict(light_in_camera=True)))
    if any(isinstance(light, (DirectionalLight, SpotLight)) for light in scene.lights):
        out.append(("light-reversed", "the light's direction d used as s where s = -d (lit from the opposite side)",
                    "Vector formulation", dict(light_reversed=True)))
    if points and any(np.any(np.mean(m.mesh.bounds, axis=0) != 0.0) for m in scene.models):
        out.append(("light-object-space", "light positions read in the object's frame (its centre), not the world's",
                    "Vector Notation", dict(light_object=True)))
    if encoding != "linear":
        out.append(("no-srgb", "linear values written without the sRGB encoding", _OUTPUT, dict(encoding="linear")))
    else:
        out.append(("srgb-applied", "sRGB encoded where linear values are asked for", _OUTPUT,
                    dict(encoding="srgb")))
    out += [
        ("srgb-twice", "the sRGB encoding applied twice", _OUTPUT, dict(encoding="double")),
        ("flipped", "rows written bottom-up (image flipped vertically)", _OUTPUT, dict(flip=True)),
        ("half-pixel", "rays through pixel corners (x, y) instead of centres (x + 0.5, y + 0.5)", _OUTPUT,
         dict(half_pixel=True)),
        ("bgr", "red and blue channels swapped (BGR)", _OUTPUT, dict(bgr=True)),
    ]
    return out


_PAIRS = (("s-unnormalised", "v-unnormalised"), ("n.s-unclamped", "specular-ungated"), ("flipped", "bgr"),
          ("no-srgb", "attenuation-none"), ("no-srgb", "flipped"), ("no-srgb", "no-ambient"),
          ("gouraud-shading", "no-srgb"))


def catalogue(method: str, scene, encoding: str = "srgb") -> tuple:
    """The candidates for an image that should have been rendered with ``method``.

    Parameters
    ----------
    method : {"flat", "gouraud", "phong"}
    scene : Scene
        Candidates that cannot change this scene's image by construction are
        left out (attenuation laws without point lights, the law the lights
        already have, Phong-only slips under other methods).
    encoding : {"srgb", "linear", "auto"}
        The encoding a correct image has; ``"auto"``: either counts as
        correct.

    Returns
    -------
    tuple of Candidate
        ``"correct"`` first, then single slips, then common pairs.
    """
    if encoding not in ENCODING_CHOICES:
        raise ValueError(f"encoding: expected one of {list(ENCODING_CHOICES)}, got {encoding!r}")
    base = Mistake(encoding="linear" if encoding == "linear" else "srgb")
    out = [Candidate("correct", f"our {method.capitalize()} shading, the lecture's equation", _METHOD_SLIDES[method],
                     base, True)]
    singles = _single(method, scene, encoding)
    if encoding == "auto":
        singles = [s for s in singles if s[0] != "no-srgb"]
        out.append(Candidate("correct-linear", f"our {method.capitalize()} shading, written as linear values",
                             _OUTPUT, Mistake(encoding="linear"), True))
    by_name = {}
    for name, text, slide, changes in singles:
        cand = Candidate(name, text, slide, Mistake(**{**base.changes(), **changes}))
        by_name[name] = cand
        out.append(cand)
    for a, b in _PAIRS:
        if a in by_name and b in by_name:
            ca, cb = by_name[a], by_name[b]
            out.append(Candidate(f"{a}+{b}", f"{ca.text}; and {cb.text}", f"{ca.slide}; {cb.slide}",
                                 ca.mistake.combine(cb.mistake)))
    return tuple(out)
