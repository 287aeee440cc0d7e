"""The ``raycast-shade`` command: ``demo``, ``render`` (a scene file or a mesh file), ``inspect``
(:mod:`raycast_shade.apps.inspect`), ``animate`` (:mod:`raycast_shade.apps.animate`), ``views``
(:mod:`raycast_shade.apps.views`) and ``info``.

Every failure the user can fix (a missing or invalid scene file, a bad option
value, an unwritable output) prints one line ``raycast-shade: error: ...`` on
stderr and exits with status 2, without a traceback.

Heavy modules are imported inside the commands: the demo must not pay for
trimesh (about half a second) unless a scene loads a mesh file or a shape
that needs it.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
import warnings

from ..common.choices import EIGHT_BIT_EXTS, LINEAR_EXTS
from .args import add_render_options, add_tone_options, overrides, positive_int, shading_label

__all__ = ["main", "build_parser"]

PROG = "raycast-shade"

_EPILOG = """\
examples:
  raycast-shade demo                                   # writes demo.png
  raycast-shade demo -o demo.png --width 640 --height 200
  raycast-shade render examples/shapes.toml            # writes shapes.png
  raycast-shade render examples/knot.toml --shading gouraud -o knot.png
  raycast-shade render scene.toml --width 320 --height 240 --exposure 1.5 --tonemap reinhard
  raycast-shade render scene.toml -o scene.pfm         # linear float32, lossless
  raycast-shade render model.glb -o model.png          # a mesh file, framed and lit
  raycast-shade inspect model.glb                      # what the file holds, what it became
  raycast-shade info

Scene files are TOML; see docs/scene-files.md for the format.
"""


class _UsageError(Exception):
    """A command-line mistake; reported on one line with exit status 2."""


class _Parser(argparse.ArgumentParser):
    def error(self, message):
        # argparse would print the usage block too; one line is easier to read
        # and to grep, and --help is one command away.
        raise _UsageError(f"{message} (see {self.prog} --help)")


def _add_output_option(p, default_output: str | None):
    default = f" (default: {default_output})" if default_output else " (default: the scene file's name, .png, here)"
    p.add_argument("-o", "--output", metavar="PATH",
                   help=f"image to write: {', '.join(EIGHT_BIT_EXTS)} (tone-mapped 8-bit), "
                        f"{' or '.join(LINEAR_EXTS)} (linear float32){default}")
    add_tone_options(p)


def build_parser() -> argparse.ArgumentParser:
    """The argument parser (exposed for documentation tools and tests)."""
    from ..common.version import __version__
    from .demo import DEFAULT_HEIGHT, DEFAULT_WIDTH

    parser = _Parser(
        prog=PROG,
        description="Shaded images of triangle meshes by ray casting (Embree hits, Numba flat/Gouraud/Phong).",
        epilog=_EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--version", action="version", version=f"%(prog)s {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)

    demo = sub.add_parser(
        "demo", help="render the built-in demo: one scene, flat | Gouraud | Phong",
        description="Render the built-in procedural scene three times (flat, Gouraud, Phong) and stack the "
                    "panels top to bottom in one labelled image.",
        epilog="example:\n  raycast-shade demo -o demo.png --width 640 --height 200",
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    demo.add_argument("--width", type=positive_int, default=DEFAULT_WIDTH, metavar="W",
                      help="panel width (default: %(default)s)")
    demo.add_argument("--height", type=positive_int, default=DEFAULT_HEIGHT, metavar="H",
                      help="panel height; the image is 3 H + 4 pixels tall (default: %(default)s)")
    demo.add_argument("--no-labels", action="store_true", help="leave out the FLAT / GOURAUD / PHONG labels")
    _add_output_option(demo, "demo.png")

    render = sub.add_parser(
        "render", help="render a TOML scene file, or a mesh file as it is",
        description="Render a TOML scene file (format: docs/scene-files.md). Options given here override the "
                    "file's [render] table, which overrides its [camera] size. Any other file is a mesh file "
                    "(OBJ, glTF/GLB, PLY, OFF, STL, ...): rendered with its own materials, framed by "
                    "Camera.fit, lit by a headlight and a key light (--shading phong unless given).",
        epilog="examples:\n"
               "  raycast-shade render examples/shapes.toml -o shapes.png\n"
               "  raycast-shade render examples/knot.toml --shading flat --width 320 --height 240\n"
               "  raycast-shade render scene.toml --backend raster --interpolation screen -o scan.png\n"
               "  raycast-shade render Duck.glb --shading gouraud --width 320 --height 240",
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    render.add_argument("scene", metavar="SCENE.toml|MODEL", help="scene file, or a mesh file")
    add_render_options(render)
    _add_output_option(render, None)

    from .animate import register_cli

    register_cli(sub)

    from .views import register_cli as register_views

    register_views(sub)

    from .inspect import register_cli as register_inspect

    register_inspect(sub)

    from .diagnose import register_cli as register_diagnose

    register_diagnose(sub)

    from .warmup import register_cli as register_warmup

    register_warmup(sub)

    sub.add_parser("info", help="versions and the Embree library in use",
                   description="Print the versions of raycast_shade and its engines, and the Embree library path.")
    return parser


def _ms(seconds: float) -> str:
    ms = seconds * 1e3
    return f"{ms:.1f} ms" if ms < 10 else f"{ms:.0f} ms"


def _timing_line(out: str, what: str, timings: dict) -> str:
    parts = ", ".join(f"{k} {_ms(v)}" for k, v in timings.items())
    return f"wrote {out} ({what}): {parts}"


def _check_output(path: str) -> str:
    """Fail before rendering, not after, on an output that cannot be written."""
    from ..output.imagefile import check_image_path

    check_image_path(path, "output", writable=True)
    folder = os.path.dirname(os.path.abspath(path))
    if not os.path.isdir(folder):
        raise _UsageError(f"output {path!r}: folder {folder} does not exist")
    return path


def _check_tone_for(out: str, args) -> None:
    """Tone flags with a lossless float output would be dropped: refuse them before rendering."""
    from ..output.imagefile import LINEAR_EXTS
    from ..scene.scenefile import TONE_KEYS

    given = [k for k, v in overrides(args).items() if k in TONE_KEYS and v is not None]
    if given and os.path.splitext(out)[1].lower() in LINEAR_EXTS:
        flags = ", ".join("--" + k for k in given)
        raise _UsageError(f"{flags}: tone options apply to 8-bit outputs; {out} stores the linear float32 image "
                          "as is: leave them out, or write an 8-bit format such as .png")


def _save(path: str, frame) -> float:
    """Write a frame with its tone options (:meth:`Frame.save`); returns seconds."""
    t0 = time.perf_counter()
    frame.save(path)
    return time.perf_counter() - t0


def _cmd_demo(args) -> int:
    from ..output.imagefile import write_image
    from ..scene.scenefile import TONE_KEYS
    from .demo import LABELS, compose, render_demo_frames

    out = _check_output(args.output or "demo.png")
    _check_tone_for(out, args)
    tone = {k: v for k, v in overrides(args).items() if k in TONE_KEYS}
    t0 = time.perf_counter()
    frames = render_demo_frames(args.width, args.height)
    image = compose([f.image for f in frames], None if args.no_labels else LABELS)
    timings = {}
    for f in frames:
        for k, v in f.timings.items():
            if k != "total":
                timings[k] = timings.get(k, 0.0) + v
    ts = time.perf_counter()
    write_image(out, image, **tone)
    timings["save"] = time.perf_counter() - ts
    timings["total"] = time.perf_counter() - t0
    h, w = image.shape[:2]
    print(_timing_line(out, f"{w}x{h}, flat | gouraud | phong", timings))
    return 0


def _cmd_render(args) -> int:
    from ..render import render_file

    out = _check_output(args.output or os.path.splitext(os.path.basename(args.scene))[0] + ".png")
    _check_tone_for(out, args)
    t0 = time.perf_counter()
    if not args.scene.lower().endswith(".toml"):
        frame = _render_model(args.scene, overrides(args))
    else:
        frame = None
    try:
        frame = frame or render_file(args.scene, **overrides(args))
    except ImportError as exc:
        raise RuntimeError(f"{args.scene}: its pipeline options are not available in this installation "
                           f"({exc})") from None
    # Everything but the render is the loading of the file (and its meshes).
    timings = {"load": time.perf_counter() - t0 - frame.timings["total"]}
    timings.update((k, v) for k, v in frame.timings.items() if k != "total")
    timings["save"] = _save(out, frame)
    timings["total"] = time.perf_counter() - t0
    camera = frame.camera
    what = "auto" if frame.decisions else shading_label(frame.shading)
    print(_timing_line(out, f"{camera.width}x{camera.height}, {what}", timings))
    for d in frame.decisions:  # shading="auto": what each model got, and why
        print(f"  {d.name}: {d.method} ({d.reason})")
    return 0


def _render_model(path: str, given: dict):
    """``render MODEL``: the mesh file framed and lit (:func:`~raycast_shade.scene.meshfile.model_scene`)."""
    from ..render import render
    from ..scene.meshfile import model_scene
    from ..scene.scenefile import check_render_options, split_options

    size, kwargs, tone = split_options(check_render_options({k: v for k, v in given.items() if v is not None}))
    kwargs.setdefault("shading", "phong")
    if isinstance(kwargs["shading"], tuple):
        raise _UsageError("--shading: one method for a mesh file (per-model lists need a scene file)")
    scene = model_scene(path, **size)
    return render(scene, **kwargs).with_tone(tone)


def _cmd_info(args) -> int:
    import platform
    from importlib import metadata

    from ..common.version import __version__
    from ..visibility import embree

    def version(dist):
        try:
            return metadata.version(dist)
        except metadata.PackageNotFoundError:
            return "not installed"

    rows = [("raycast_shade", __version__), ("python", platform.python_version())]
    rows += [(d, version(d)) for d in ("numpy", "numba", "llvmlite", "embreex", "trimesh", "scipy", "imageio")]
    if embree.available():
        rows += [("embree", embree.embree_version()), ("embree library", embree.library_path()),
                 ("caster", "embree (direct, packet traced)")]
    else:
        rows += [("embree", f"unavailable: {embree._load()[1]}"), ("caster", "embreex (fallback)")]
    import numba

    rows.append(("numba threads", str(numba.config.NUMBA_NUM_THREADS)))
    width = max(len(k) for k, _ in rows)
    for k, v in rows:
        print(f"{k:<{width}}  {v}")
    return 0


def _one_line(exc: BaseException) -> str:
    if isinstance(exc, OSError) and exc.strerror and exc.filename:
        return f"{exc.filename}: {exc.strerror}"
    return " ".join(str(exc).split()) or type(exc).__name__


def _show_warning(message, category, filename, lineno, file=None, line=None) -> None:
    """Print a warning (an inconsistently wound mesh, say) as one line, like errors."""
    print(f"{PROG}: warning: {_one_line(message)}", file=sys.stderr)


def main(argv=None) -> int:
    """Run the command line.

    Parameters
    ----------
    argv : list of str, optional
        Arguments without the program name (default: ``sys.argv[1:]``).

    Returns
    -------
    int
        Exit status: 0 on success, 2 on any error the user can fix.
    """
    try:
        parser = build_parser()
        try:
            args = parser.parse_args(argv)
        except SystemExit as exc:  # --help and --version
            return exc.code if isinstance(exc.code, int) else 0
        if getattr(args, "output", None) == "":  # would fall back to the default name without a word
            raise _UsageError("argument -o/--output: expected a path, got an empty string")
        if args.command == "animate":
            from .animate import run_cli as command
        elif args.command == "views":
            from .views import run_cli as command
        elif args.command == "inspect":
            from .inspect import run_cli as command
        elif args.command == "diagnose":
            from .diagnose import run_cli as command
        elif args.command == "warmup":
            from .warmup import run_cli as command
        else:
            command = {"demo": _cmd_demo, "render": _cmd_render, "info": _cmd_info}[args.command]
        with warnings.catch_warnings():  # restores showwarning on the way out
            warnings.showwarning = _show_warning
            return command(args)
    except (_UsageError, ValueError, TypeError, OSError, RuntimeError, ArithmeticError) as exc:
        print(f"{PROG}: error: {_one_line(exc)}", file=sys.stderr)
        return 2
    except MemoryError as exc:  # inputs are checked against memory_limit(); this is what remains
        print(f"{PROG}: error: out of memory{': ' + _one_line(exc) if str(exc) else ''}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        return 130
