"""Command-line argument types and the option groups several commands share.

``raycast-shade render`` and ``raycast-shade animate`` take the same render
options (:func:`add_render_options`) and every command the same tone options
(:func:`add_tone_options`); their choices come from
:mod:`raycast_shade.common.choices` and are case-insensitive, and
:func:`overrides` hands what was given to the scene file's checks
(:func:`raycast_shade.scene.scenefile.check_render_options`), so the command
line accepts what a scene file and Python accept.
"""

from __future__ import annotations

import argparse

import numpy as np

from ..common.choices import (BACKEND_CHOICES, CASTER_CHOICES, INTERPOLATIONS, REFLECTANCES, SHADING_CHOICES, SHADINGS,
                              TONEMAPS)
from ..common.samples import MAX_SAMPLES
from ..scene.scenefile import RENDER_KEYS

__all__ = ["positive_int", "nonnegative_int", "positive_float", "finite_float", "gamma", "shading",
           "add_render_options", "add_mesh_options", "add_tone_options", "overrides", "run_options", "shading_label",
           "buffer_list"]


def _int_at_least(text: str, low: int) -> int:
    """``text`` as an integer ``>= low``, or the ``ArgumentTypeError`` argparse prints."""
    want = "an integer > 0" if low == 1 else f"an integer >= {low}"
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected {want}, got {text!r}") from None
    if value < low:
        raise argparse.ArgumentTypeError(f"expected {want}, got {text!r}")
    return value


def positive_int(text: str) -> int:
    return _int_at_least(text, 1)


def nonnegative_int(text: str) -> int:
    return _int_at_least(text, 0)


def positive_float(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number > 0, got {text!r}") from None
    if not (value > 0 and value < float("inf")):
        raise argparse.ArgumentTypeError(f"expected a finite number > 0, got {text!r}")
    return value


def crease_angle(text: str) -> float:
    """Degrees in (0, 180], as :class:`~raycast_shade.scene.mesh.Mesh` takes ``crease_angle``."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected degrees in (0, 180], got {text!r}") from None
    if not 0.0 < value <= 180.0:
        raise argparse.ArgumentTypeError(f"expected degrees in (0, 180], got {text!r}")
    return value


def add_mesh_options(p) -> None:
    """--crease-angle: how a mesh file's computed vertex normals treat sharp edges."""
    p.add_argument("--crease-angle", type=crease_angle, metavar="DEG",
                   help="a mesh file whose normals are computed (none in the file): edges whose faces meet at "
                        "more than DEG degrees stay hard (default: every edge smoothed; a warning counts the "
                        "edges sharper than 60); a scene file sets crease_angle per [[object]]")
    p.add_argument("--reflectance", type=str.lower, choices=REFLECTANCES,
                   help="a glTF file's materials: phong (the default) maps metallic-roughness onto the lecture's "
                        "ka, kd, ks, t; pbr shades them with glTF's own BRDF (GGX; docs/pbr.md)")


def scene_file_refuses_mesh_options(ns) -> None:
    """--crease-angle and --reflectance are a mesh file's: a scene file sets them per [[object]] (ValueError)."""
    for flag, value, there in (("--crease-angle", ns.crease_angle, "sets crease_angle per [[object]]"),
                               ("--reflectance", ns.reflectance, "gives each [[object]] its material")):
        if value is not None:
            raise ValueError(f"{flag}: for a mesh file; a scene file {there}")


def finite_float(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
    if not np.isfinite(value):
        raise argparse.ArgumentTypeError(f"expected a finite number, got {text!r}")
    return value


def gamma(text: str):
    if text.lower() == "srgb":
        return "srgb"
    try:
        return positive_float(text)
    except argparse.ArgumentTypeError:
        raise argparse.ArgumentTypeError(f"expected 'srgb' or a number > 0, got {text!r}") from None


def shading(text: str):
    """A method or ``auto`` (any case), or one method per model: ``flat,phong``."""
    names = [t.strip().lower() for t in text.split(",")]
    if len(names) == 1 and names[0] in SHADING_CHOICES:
        return names[0]
    bad = next((n for n in names if n not in SHADINGS), None) if len(names) > 1 else text
    if bad is not None:
        raise argparse.ArgumentTypeError(f"invalid choice: {bad!r} (choose from {', '.join(SHADING_CHOICES)}, "
                                         f"or one of {', '.join(SHADINGS)} per model, comma-separated)")
    return tuple(names)


def shading_label(value) -> str:
    """How a shading value reads on the command line."""
    return value if isinstance(value, str) else ",".join(value)


def _choice(parser, flag: str, choices, help: str, default_text: str):
    parser.add_argument(flag, type=str.lower, choices=choices, help=f"{help} (default: {default_text})")


def add_render_options(p) -> None:
    """--shading, --tolerance, --width, --height and the pipeline group (with --samples) of ``p``.

    Every default is None: the scene file's ``[render]`` value, else the library's.
    """
    p.add_argument("--shading", type=shading, metavar="{" + ",".join(SHADING_CHOICES) + "}",
                   help="shading method, any case; auto picks per model the cheapest method within --tolerance; "
                        "or one method per [[object]], comma-separated (default: the file's [render] shading, "
                        "else phong)")
    p.add_argument("--tolerance", type=positive_float, metavar="E",
                   help="error budget of --shading auto, linear intensity (default: the file's, else 0.01)")
    p.add_argument("--width", type=positive_int, metavar="W", help="image width in pixels")
    p.add_argument("--height", type=positive_int, metavar="H", help="image height in pixels")
    adv = p.add_argument_group("pipeline")
    _choice(adv, "--caster", CASTER_CHOICES, "ray caster: direct Embree packets, or embreex's API",
            "the file's, else auto")
    _choice(adv, "--backend", BACKEND_CHOICES,
            "visibility by ray casting, by the reference z-buffer rasterizer, or auto (the faster)",
            "the file's, else raycast")
    _choice(adv, "--interpolation", INTERPOLATIONS,
            "barycentrics of the 3D hit point, or affine in screen space", "the file's, else perspective")
    adv.add_argument("--max-depth", type=nonnegative_int, metavar="N",
                     help="mirror bounces for reflective materials (default: the file's [render] max_depth, else 3)")
    adv.add_argument("--samples", type=positive_int, metavar="N",
                     help=f"anti-aliasing rays per pixel, 1 to {MAX_SAMPLES}, averaged over the pixel (box filter) "
                          "(default: the file's [render] samples, else 1)")


def add_tone_options(p, title: str = "tone mapping (8-bit formats only)") -> None:
    """--exposure, --tonemap, --gamma, in their own group of ``p``."""
    tone = p.add_argument_group(title)
    tone.add_argument("--exposure", type=positive_float, metavar="E", help="multiply the radiance by E (default: 1)")
    tone.add_argument("--tonemap", type=str.lower, choices=TONEMAPS,
                      help="range compression (default: clamp, which keeps values <= 1 exact)")
    tone.add_argument("--gamma", type=gamma, metavar="G|srgb", help="encoding: srgb (default), or x**(1/G)")


def overrides(args) -> dict:
    """The ``[render]`` options given on the command line (those not None)."""
    return {k: getattr(args, k) for k in RENDER_KEYS if getattr(args, k, None) is not None}


def run_options(ns):
    """The execution flags a command has (``--workers``, ``--scheduler``, ``--executor``,
    ``--frames-per-task``, ``--no-progress``) as one
    :class:`~raycast_shade.apps.batch.run.RunOptions`: the record the Python front ends take, checked
    by it. A flag the command lacks keeps the record's default."""
    from .batch.run import RunOptions

    return RunOptions(workers=getattr(ns, "workers", None), scheduler=getattr(ns, "scheduler", None),
                      executor=getattr(ns, "executor", "auto"), per_task=getattr(ns, "frames_per_task", None),
                      progress=not getattr(ns, "no_progress", False))


def buffer_list(text: str) -> tuple:
    """Comma-separated buffer names (:mod:`raycast_shade.output.buffers`), any case."""
    from ..output.buffers import check_buffers

    try:
        return check_buffers(text, "--buffers")
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc).removeprefix("--buffers: ")) from None


def model_for_render(path: str, given: dict, crease_angle: float | None = None, reflectance: str | None = None):
    """A mesh file (not a TOML scene) as ``render`` and ``views`` take it: framed and lit by
    :func:`~raycast_shade.scene.meshfile.model_scene`, with the command line's options.

    Parameters
    ----------
    path : str
        Any file :func:`raycast_shade.load_models` reads.
    given : dict
        The command line's ``[render]`` options (:func:`overrides`); ``None`` for not given.
    crease_angle : float, optional
        ``--crease-angle``: passed to :func:`raycast_shade.load_models` (None: not given).
    reflectance : {"phong", "pbr"}, optional
        ``--reflectance``: likewise.

    Returns
    -------
    scene : Scene
    render_kwargs : dict
        ``shading`` (default ``"phong"``) and the pipeline options given.
    tone : dict

    Raises
    ------
    ValueError
        For a per-model ``--shading`` list (a mesh file's models are not named on the command line).
    """
    from ..scene.meshfile import model_scene
    from ..scene.scenefile import check_render_options, split_options

    size, kwargs, tone = split_options(check_render_options({k: v for k, v in given.items() if v is not None}))
    kwargs.setdefault("shading", "phong")
    if isinstance(kwargs["shading"], tuple):
        raise ValueError("--shading: one method for a mesh file (per-model lists need a scene file)")
    load = {k: v for k, v in (("crease_angle", crease_angle), ("reflectance", reflectance)) if v is not None}
    return model_scene(path, **size, **load), kwargs, tone
