"""The ``raycast-shade`` command: ``demo``, ``render`` and ``info``.

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


def _positive_int(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected an integer > 0, got {text!r}") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"expected an integer > 0, got {text!r}")
    return value


def _nonnegative_int(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected an integer >= 0, got {text!r}") from None
    if value < 0:
        raise argparse.ArgumentTypeError(f"expected an integer >= 0, got {text!r}")
    return value


def _positive_float(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number > 0, got {text!r}") from None
    if not (value > 0 and value < float("inf")):
        raise argparse.ArgumentTypeError(f"expected a finite number > 0, got {text!r}")
    return value


def _gamma(text: str):
    if text.lower() == "srgb":
        return "srgb"
    try:
        return _positive_float(text)
    except argparse.ArgumentTypeError:
        raise argparse.ArgumentTypeError(f"expected 'srgb' or a number > 0, got {text!r}") from None


def _add_output_options(p, default_output: str | None):
    default = f" (default: {default_output})" if default_output else " (default: the scene file's name, .png, here)"
    p.add_argument("-o", "--output", metavar="PATH",
                   help=f"image to write: .png, .jpg, .bmp, .tif, .gif, .webp (tone-mapped 8-bit), .pfm or .npy (linear float32){default}")
    tone = p.add_argument_group("tone mapping (8-bit formats only)")
    tone.add_argument("--exposure", type=_positive_float, metavar="E", help="multiply the radiance by E (default: 1)")
    tone.add_argument("--tonemap", choices=("clamp", "reinhard", "exponential"),
                      help="range compression (default: clamp, which keeps values <= 1 exact)")
    tone.add_argument("--gamma", type=_gamma, metavar="G|srgb", help="encoding: srgb (default), or x**(1/G)")


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
    demo.add_argument("--width", type=_positive_int, default=DEFAULT_WIDTH, metavar="W",
                      help="panel width (default: %(default)s)")
    demo.add_argument("--height", type=_positive_int, default=DEFAULT_HEIGHT, metavar="H",
                      help="panel height; the image is 3 H + 4 pixels tall (default: %(default)s)")
    demo.add_argument("--no-labels", action="store_true", help="leave out the FLAT / GOURAUD / PHONG labels")
    _add_output_options(demo, "demo.png")

    render = sub.add_parser(
        "render", help="render a TOML scene file",
        description="Render a TOML scene file (format: docs/scene-files.md). Options given here override the "
                    "file's [render] table, which overrides its [camera] size.",
        epilog="examples:\n"
               "  raycast-shade render examples/shapes.toml -o shapes.png\n"
               "  raycast-shade render examples/knot.toml --shading flat --width 320 --height 240\n"
               "  raycast-shade render scene.toml --backend raster --interpolation screen -o scan.png",
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    render.add_argument("scene", metavar="SCENE.toml", help="scene file")
    render.add_argument("--shading", choices=("flat", "gouraud", "phong", "auto"),
                        help="shading mode; auto picks per model the cheapest method within --tolerance "
                             "(default: the file's [render] shading, else phong)")
    render.add_argument("--tolerance", type=float, default=0.01, metavar="E",
                        help="error budget of --shading auto, linear intensity (default: %(default)s)")
    render.add_argument("--width", type=_positive_int, metavar="W", help="image width in pixels")
    render.add_argument("--height", type=_positive_int, metavar="H", help="image height in pixels")
    _add_output_options(render, None)
    adv = render.add_argument_group("pipeline")
    adv.add_argument("--caster", choices=("auto", "embree", "embreex"), default="auto",
                     help="ray caster: direct Embree packets, or embreex's API (default: auto)")
    adv.add_argument("--backend", choices=("raycast", "raster"), default="raycast",
                     help="visibility by ray casting or by the reference z-buffer rasterizer (default: raycast)")
    adv.add_argument("--interpolation", choices=("perspective", "screen"), default="perspective",
                     help="barycentrics of the 3D hit point, or affine in screen space (default: perspective)")
    adv.add_argument("--max-depth", type=_nonnegative_int, metavar="N",
                     help="mirror bounces for reflective materials (default: the file's [render] max_depth, else 3)")

    from .animate import register_cli

    register_cli(sub)

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


def _tone_kwargs(args, options: dict) -> dict:
    kw = {}
    for key in ("exposure", "tonemap", "gamma"):
        value = getattr(args, key)
        if value is None:
            value = options.get(key)
        if value is not None:
            kw[key] = value
    return kw


def _save(path: str, image, tone: dict) -> float:
    """Write a linear float image like :meth:`Frame.save`; returns seconds."""
    from ..output.imagefile import write_image

    t0 = time.perf_counter()
    write_image(path, image, **tone)
    return time.perf_counter() - t0


def _cmd_demo(args) -> int:
    from .demo import LABELS, compose, render_demo_frames

    out = _check_output(args.output or "demo.png")
    tone = _tone_kwargs(args, {})
    t0 = time.perf_counter()
    frames = render_demo_frames(args.width, args.height)
    image = compose([f.image for f in frames], None if args.no_labels else LABELS)
    timings = {}
    for f in frames:
        for k, v in f.timings.items():
            if k != "total":
                timings[k] = timings.get(k, 0.0) + v
    timings["save"] = _save(out, image, tone)
    timings["total"] = time.perf_counter() - t0
    h, w = image.shape[:2]
    print(_timing_line(out, f"{w}x{h}, flat | gouraud | phong", timings))
    return 0


def _cmd_render(args) -> int:
    from ..render import render
    from ..scene.scenefile import load_scene

    out = _check_output(args.output or os.path.splitext(os.path.basename(args.scene))[0] + ".png")
    t0 = time.perf_counter()
    scene, options = load_scene(args.scene)
    t_load = time.perf_counter() - t0
    camera = scene.camera
    size = {k: v for k, v in (("width", args.width), ("height", args.height)) if v is not None}
    if size:
        camera = camera.replace(**size)
    shading = args.shading or options.get("shading", "phong")
    tone = _tone_kwargs(args, options)
    extra = {}
    max_depth = args.max_depth if args.max_depth is not None else options.get("max_depth")
    if max_depth is not None:
        extra["max_depth"] = max_depth
    try:
        frame = render(scene, shading, camera=camera, backend=args.backend, interpolation=args.interpolation,
                       caster=args.caster, tolerance=args.tolerance, **extra)
    except ImportError as exc:
        raise RuntimeError(f"--backend {args.backend} --interpolation {args.interpolation} is not available in "
                           f"this installation ({exc})") from None
    timings = {"load": t_load}
    timings.update((k, v) for k, v in frame.timings.items() if k != "total")
    timings["save"] = _save(out, frame.image, tone)
    timings["total"] = time.perf_counter() - t0
    print(_timing_line(out, f"{camera.width}x{camera.height}, {shading}", timings))
    for d in frame.decisions:  # shading="auto": what each model got, and why
        print(f"  {d.name}: {d.method} ({d.reason})")
    return 0


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
