"""The ``raycast-shade`` command: {names}.

One entry of :data:`COMMANDS` per subcommand (its name, one-line help, parser builder and
runner): the parser, the dispatch and the list above come from it, and
``tests/apps/test_cli_registry.py`` checks that the README's "Command line" block shows
every registered subcommand, and that the README, ``docs/*.md`` and the package name no other. Adding one is its entry here, its builder and runner
(in a module of its own, imported on first use), a line in the README's "Command line"
block, and its tests.

Every failure the user can fix (a missing or invalid scene file, a bad option
value, an unwritable output) prints one line ``raycast-shade: error: ...`` on
stderr and exits with status 2, without a traceback.

Heavy modules are imported inside the commands: the demo must not pay for
trimesh (about half a second) unless a scene loads a mesh file or a shape
that needs it.
"""

from __future__ import annotations

import argparse
import dataclasses
import importlib
import os
import sys
import time
import warnings
from typing import Callable

from ..common.choices import EIGHT_BIT_EXTS, LINEAR_EXTS
from .args import (add_mesh_options, add_render_options, add_tone_options, overrides, positive_int,
                   scene_file_refuses_mesh_options, shading_label)

__all__ = ["main", "build_parser", "Subcommand", "COMMANDS"]

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
    """The argument parser (exposed for documentation tools and tests): one subparser per
    entry of :data:`COMMANDS`, in order."""
    from ..common.version import __version__

    parser = _Parser(
        prog=PROG,
        description="Shaded images of triangle meshes by ray casting (Embree hits, Numba flat/Gouraud/Phong).",
        epilog=_EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--version", action="version", version=f"%(prog)s {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for command in COMMANDS:
        _add_subcommand(sub, command)
    return parser


class _OneSubcommand:
    """``add_subparsers()``'s action as one builder sees it: ``add_parser`` adds that
    subcommand only, with the registry's help (a builder's own ``help=`` is kept in
    ``given_help`` for the test that it agrees)."""

    def __init__(self, subparsers, command: "Subcommand"):
        self._subparsers = subparsers
        self._command = command
        self.parser = None
        self.given_help = None

    def add_parser(self, name, **kwargs):
        if name != self._command.name or self.parser is not None:
            raise ValueError(f"the builder of {self._command.name!r} adds {name!r}: one subparser, of its own name")
        self.given_help = kwargs.pop("help", None)
        self.parser = self._subparsers.add_parser(name, help=self._command.help, **kwargs)
        return self.parser


def _add_subcommand(subparsers, command: "Subcommand") -> _OneSubcommand:
    """Add ``command``'s subparser to ``subparsers`` (what ``add_subparsers()`` returned).

    Returns
    -------
    _OneSubcommand
        Its ``parser``, and the help its builder passed itself (``given_help``, or None).
    """
    one = _OneSubcommand(subparsers, command)
    command.builder()(one)
    if one.parser is None:
        raise ValueError(f"the builder of {command.name!r} added no subparser")
    return one


def _build_demo(sub) -> argparse.ArgumentParser:
    from .demo import DEFAULT_HEIGHT, DEFAULT_WIDTH

    demo = sub.add_parser(
        "demo",
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
    return demo


def _build_render(sub) -> argparse.ArgumentParser:
    render = sub.add_parser(
        "render",
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
    add_mesh_options(render)
    _add_output_option(render, None)
    return render


def _build_info(sub) -> argparse.ArgumentParser:
    return sub.add_parser(
        "info", description="Print the versions of raycast_shade and its engines, and the Embree library path.")


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
        frame = _render_model(args.scene, overrides(args), args.crease_angle, args.reflectance)
    else:
        try:
            scene_file_refuses_mesh_options(args)
        except ValueError as exc:
            raise _UsageError(str(exc)) from None
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


def _render_model(path: str, given: dict, crease_angle=None, reflectance=None):
    """``render MODEL``: the mesh file framed and lit (:func:`~raycast_shade.scene.meshfile.model_scene`)."""
    from ..render import render
    from .args import model_for_render

    scene, kwargs, tone = model_for_render(path, given, crease_angle, reflectance)
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


@dataclasses.dataclass(frozen=True)
class Subcommand:
    """One ``raycast-shade`` subcommand: an entry of :data:`COMMANDS`.

    Parameters
    ----------
    name : str
        What follows ``raycast-shade`` on the command line.
    help : str
        Its one line in ``raycast-shade --help`` and in this module's docstring.
    build : callable or str
        ``build(subparsers)`` adds the subcommand's parser (``subparsers.add_parser(name,
        ...)``, the help left to the registry); a ``"module:function"`` string, relative
        to this package, is imported when the parser is built.
    run : callable or str
        ``run(args) -> int``: the exit status, given the parsed arguments; a string as for
        ``build``.
    """

    name: str
    help: str
    build: Callable | str
    run: Callable | str

    def builder(self) -> Callable:
        """``build``, imported if need be."""
        return _resolve(self.build)

    def runner(self) -> Callable:
        """``run``, imported if need be."""
        return _resolve(self.run)


def _resolve(ref):
    if callable(ref):
        return ref
    module, name = ref.split(":")
    return getattr(importlib.import_module(module, __package__), name)


COMMANDS = (
    Subcommand("demo", "render the built-in demo: one scene, flat | Gouraud | Phong", _build_demo, _cmd_demo),
    Subcommand("render", "render a TOML scene file, or a mesh file as it is", _build_render, _cmd_render),
    Subcommand("animate", "render a camera turntable or a light orbit as GIF, MP4 or PNG frames",
               ".animate:register_cli", ".animate:run_cli"),
    Subcommand("views", "render a data set of views: images, buffers and cameras",
               ".views:register_cli", ".views:run_cli"),
    Subcommand("inspect", "what a mesh file holds and what each field became",
               ".inspect:register_cli", ".inspect:run_cli"),
    Subcommand("diagnose", "say which lecture choice or common mistake explains a student's image",
               ".diagnose:register_cli", ".diagnose:run_cli"),
    Subcommand("warmup", "compile every kernel into the cache (run once before class)",
               ".warmup:register_cli", ".warmup:run_cli"),
    Subcommand("info", "versions and the Embree library in use", _build_info, _cmd_info),
)
_BY_NAME = {c.name: c for c in COMMANDS}
__doc__ = __doc__.format(names=", ".join(f"``{c.name}``" for c in COMMANDS[:-1]) + f" and ``{COMMANDS[-1].name}``")


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
        command = _BY_NAME[args.command].runner()
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
