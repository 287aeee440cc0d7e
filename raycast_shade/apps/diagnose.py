"""Diagnose a student's image: which choice of the lecture, or which slip, explains it.

:func:`diagnose` renders the scene with our renderer, re-shades the same hit
buffer with every candidate of the catalogue
(:mod:`raycast_shade.study.diagnose.catalogue`, each a switch of the variant
shader :mod:`raycast_shade.study.diagnose.variant`), scores each against the
student's 8-bit image on the interior pixels, and names the best, with a
per-pixel departure map and a verdict that points to one pixel and prints
our ``explain()`` beside the student's number. See ``docs/diagnose.md``.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field, replace

import numpy as np

from ..common.validate import as_bool, as_choice, as_instance, as_scalar
from ..render import render
from ..scene.pitfalls import outside_view
from ..study.diagnose.catalogue import catalogue
from ..study.diagnose.score import interior_weights, read_student, sse, sse_filtered
from ..study.diagnose.variant import check_scene, decode, encode, gather, shade_variant
from ..visibility.cast import cast_camera

__all__ = ["diagnose", "Diagnoser", "Diagnosis", "TOLERANCE", "FIT", "register_cli", "run_cli"]

TOLERANCE = 100.0  # levels^2, summed over interior pixels and channels: candidates closer than this are one class
FIT = 6.0  # levels RMS: above this no candidate explains the image well
REFIT = 6  # candidates re-scored with a fitted sub-pixel shift and blur (score.sse_filtered)
BETWEEN = 0.4  # excess / distance below which an image is between two candidates (see Diagnoser._score)
_NOTHING_IN_VIEW = ("scene: nothing of the scene is in view of the camera (no pixel sees a model: behind the camera, "
                    "or outside its view?); diagnose cannot tell anything from the image")


@dataclass(frozen=True, eq=False)
class Diagnosis:
    """What :func:`diagnose` found.

    Attributes
    ----------
    method : str
        The method the image was meant to be rendered with.
    candidates : tuple of Candidate
        The catalogue, in its order.
    scores : dict of str to float
        Each candidate's RMS difference from the image in 8-bit levels over
        the interior pixels (lower is better).
    best : Candidate
        The explanation: the simplest candidate (catalogue order) of those
        indistinguishable from the lowest-scoring one; a correct one when the
        image matches.
    group : tuple of str
        The class of the lowest-scoring candidate: candidates whose images
        differ from its by less than the tolerance on this scene
        (indistinguishable here), and those the image lies between (its
        squared error exceeds the best's by less than ``BETWEEN`` times the
        squared distance between the two: at least 30% of the way over).
    matches : bool
        A correct candidate is indistinguishable from the lowest-scoring one
        (within the tolerance, not merely between) and the fit is good.
    explained : bool
        The best candidate's RMS is at most ``FIT`` levels.
    map : (H, W) float32
        Mean absolute difference per pixel between the image and the best
        candidate, in levels; NaN where excluded (silhouettes).
    weights : (H, W) float64
        1 on the interior pixels that were scored, 0 elsewhere.
    pixel : (x, y)
        The pixel the verdict points to.
    verdict : str
        A few sentences.
    explanation : str
        Our ``frame.explain(x, y)`` printout at ``pixel``.
    """

    method: str
    candidates: tuple
    scores: dict
    best: object
    group: tuple
    matches: bool
    explained: bool
    map: np.ndarray
    weights: np.ndarray
    pixel: tuple
    verdict: str
    explanation: str = field(repr=False)

    def ranking(self, n: int = 5) -> list:
        """The ``n`` lowest-scoring candidates as (name, RMS) pairs."""
        return sorted(self.scores.items(), key=lambda kv: kv[1])[:n]

    def __str__(self) -> str:
        lines = [self.verdict, "", "lowest scores (RMS, 8-bit levels):"]
        lines += [f"  {name:<40s} {rms:8.3f}" for name, rms in self.ranking()]
        lines += ["", self.explanation]
        return "\n".join(lines)

    def __repr__(self) -> str:
        return f"Diagnosis(best={self.best.name!r}, matches={self.matches}, rms={self.scores[self.best.name]:.3g})"

    def _repr_html_(self) -> str:
        import html

        rows = "".join(f"<tr><td>{html.escape(n)}</td><td>{r:.3f}</td></tr>" for n, r in self.ranking(8))
        return (f"<p><b>{html.escape(self.verdict)}</b></p><table><tr><th>candidate</th><th>RMS (levels)</th></tr>"
                f"{rows}</table><pre>{html.escape(self.explanation)}</pre>")


def _fmt(rgb) -> str:
    return "(" + ", ".join(f"{x:.4g}" for x in rgb) + ")"


def _pick_pixel(student, best_img, correct_img, weights):
    """The interior pixel where the best explanation departs most from the correct image
    and the student agrees with it (the correct image's worst pixel when they are one)."""
    sig = np.abs(best_img - correct_img).sum(axis=2) - np.abs(student - best_img).sum(axis=2)
    if not np.any(np.abs(best_img - correct_img) > 0.5):
        sig = np.abs(student - correct_img).sum(axis=2)
    sig = np.where(weights > 0, sig, -np.inf)
    y, x = np.unravel_index(int(np.argmax(sig)), sig.shape)
    return int(x), int(y)


def _verdict(d_best, group, matches, explained, rms, pixel, student, best_img, correct_img, method, ours):
    x, y = pixel
    s8 = np.round(student[y, x]).astype(int).tolist()
    c8 = np.round(correct_img[y, x]).astype(int).tolist()
    b8 = np.round(best_img[y, x]).astype(int).tolist()
    if matches:
        head = f"Matches our {method} shading (RMS {rms:.2f} levels on the interior pixels)."
    elif explained:
        head = f"Best explained by '{d_best.name}': {d_best.text} [slide: {d_best.slide}] (RMS {rms:.2f} levels)."
    else:
        head = (f"No candidate explains the image well; the closest is '{d_best.name}': {d_best.text} "
                f"(RMS {rms:.2f} levels).")
    others = [g for g in group if g != d_best.name]
    if others:
        head += f" Cannot be told apart on this image from: {', '.join(others)}."
    where = (f" At pixel ({x}, {y}) the image has {s8} (8-bit), ours has {c8}"
             + ("" if matches else f", and '{d_best.name}' predicts {b8}") + ".")
    if not d_best.mistake.flip:
        back = decode(student[y, x], d_best.mistake)
        where += (f" Read back through {'its' if not matches else 'the'} encoding the image's value is "
                  f"I = {_fmt(back)}, beside our I = {_fmt(ours[y, x])}:")
    return head + where + " our derivation follows."


class Diagnoser:
    """The candidates of one scene and method, rendered once, for diagnosing many images.

    ``Diagnoser(scene, "phong")(image)`` is ``diagnose(image, scene, "phong")``:
    a lecturer marking a class renders the catalogue once, and each student's
    image then costs only its scoring.

    Parameters
    ----------
    scene, method, camera, encoding, tolerance
        As for :func:`diagnose`.
    filtered : bool
        Re-score the ``REFIT`` closest candidates with a fitted sub-pixel
        shift and blur (:func:`~raycast_shade.study.diagnose.score.sse_filtered`),
        so that a student's own anti-aliasing is not held against the image.

    Attributes
    ----------
    candidates : tuple of Candidate
    images : dict of str to (H, W, 3) float32
        Each candidate's image in display levels 0..255, before rounding.
    weights : (H, W) float64
        1 on the interior pixels that are scored.
    frame : Frame
        Our render in the method asked for (its ``explain`` gives the verdict's printout).
    """

    def __init__(self, scene, method: str = "phong", *, camera=None, encoding: str = "srgb",
                 tolerance: float = TOLERANCE, filtered: bool = True):
        scene, camera = _check_scene_camera(scene, camera)
        method = as_choice(method, "method", ("flat", "gouraud", "phong"))
        encoding = as_choice(encoding, "encoding", ("srgb", "linear", "auto"))
        # Levels^2 summed over the interior: past 1e12 every candidate would be one class.
        tolerance = as_scalar(tolerance, "tolerance", minimum=0.0, exclusive=True, maximum=1e12)
        self.method, self.tolerance, self.filtered = method, float(tolerance), as_bool(filtered, "filtered")
        self.camera = camera
        check_scene(scene)
        self.candidates = cands = catalogue(method, scene, encoding)
        # Nothing in view: every candidate is the background and any verdict a guess. The bounds
        # test refuses before the render when it is sure (a pinhole camera); the cast decides the rest.
        if not camera.distorted and all(outside_view(camera, m.mesh.bounds) for m in scene.models):
            raise ValueError(_NOTHING_IN_VIEW)
        self.frame = frame = render(scene, method, camera=camera)
        hits = frame.hits
        label = np.asarray(hits.geom)
        if not np.any(label >= 0):
            raise ValueError(_NOTHING_IN_VIEW)
        half = cast_camera(scene.geometry, camera, offset=(-0.5, -0.5))
        self.weights = interior_weights([label, label[::-1], np.asarray(half.geom)])
        if not self.weights.any():
            raise ValueError("scene: no interior pixel to compare (the models cover too few pixels at this size)")
        shaded, encoded, self.images = {}, {}, {}
        gathered = {False: gather(scene.geometry, hits), True: gather(scene.geometry, half)}
        for c in cands:
            key = replace(c.mistake, encoding="srgb", flip=False, bgr=False)
            if key not in shaded:
                shaded[key] = shade_variant(scene, camera, half if key.half_pixel else hits, method, key,
                                            gathered[key.half_pixel])
            enc = (key, c.mistake.encoding)  # the curve once per shading and encoding; rows and channels after
            if enc not in encoded:
                encoded[enc] = (encode(shaded[key], replace(key, encoding=c.mistake.encoding)) * 255.0
                                ).astype(np.float32)
            img = encoded[enc]
            img = img[::-1] if c.mistake.flip else img
            img = img[..., ::-1] if c.mistake.bgr else img
            self.images[c.name] = np.ascontiguousarray(img)
        del shaded

    def __call__(self, image) -> Diagnosis:
        """Diagnose one image (a file or an array, as :func:`diagnose` takes)."""
        return self._score(read_student(image, (self.camera.height, self.camera.width)))

    def _score(self, student) -> Diagnosis:
        """Diagnose ``student`` (H, W, 3) float64 levels, as :func:`read_student` returns them."""
        cands, imgs, weights = self.candidates, self.images, self.weights
        plain = {c.name: sse(student, imgs[c.name], weights) for c in cands}
        sses = dict(plain)
        if self.filtered:  # the closest few again, allowing the student's own sub-pixel sampling
            for name in sorted(plain, key=plain.get)[:REFIT]:
                sses[name] = min(plain[name], sse_filtered(student, imgs[name], weights)[0])
        n = float(weights.sum()) * 3.0
        scores = {k: float(np.sqrt(v / n)) for k, v in sses.items()}
        low = min(cands, key=lambda c: sses[c.name])
        near, group = [], []
        for c in cands:
            dist = sse(imgs[c.name], imgs[low.name], weights)
            if dist < self.tolerance:  # indistinguishable on this scene
                near.append(c.name)
            # The class also holds candidates the image lies between with the best (the unfiltered excess
            # under BETWEEN of their distance: at least 30% of the way over), which noise alone makes
            # unlikely; they can be told apart, not on this image.
            if dist < self.tolerance or plain[c.name] - plain[low.name] < BETWEEN * dist:
                group.append(c.name)
        group = tuple(group)
        explained = scores[low.name] <= FIT
        # "Matches" needs the correct image indistinguishable from the best, not merely between.
        matches = explained and any(c.correct for c in cands if c.name in near)
        if matches:
            best = next(c for c in cands if c.correct and c.name in near)
        else:
            best = next((c for c in cands if c.name in near and not c.correct), low)
        correct_img = imgs[cands[0].name]
        dep = np.abs(student - imgs[best.name]).mean(axis=2).astype(np.float32)
        dep[weights == 0] = np.nan
        pixel = _pick_pixel(student, imgs[best.name], correct_img, weights)
        verdict = _verdict(best, group, matches, explained, scores[best.name], pixel, student, imgs[best.name],
                           correct_img, self.method, self.frame.image)
        return Diagnosis(self.method, cands, scores, best, group, matches, explained, dep, weights, pixel, verdict,
                         str(self.frame.explain(*pixel)))


def _check_scene_camera(scene, camera):
    """``(scene, camera)`` checked: a Scene, and a Camera (``camera`` or the scene's own)."""
    from ..scene.camera import Camera
    from ..scene.scene import Scene

    as_instance(scene, "scene", Scene)
    if camera is not None:
        as_instance(camera, "camera", Camera)
    cam = camera if camera is not None else scene.camera
    if cam is None:
        raise ValueError("camera: the scene has no camera; pass camera=")
    return scene, cam


def diagnose(image, scene, method: str = "phong", *, camera=None, encoding: str = "srgb",
             tolerance: float = TOLERANCE) -> Diagnosis:
    """Say which of the lecture's choices or common mistakes best explains an image.

    Parameters
    ----------
    image : str, os.PathLike or array
        The student's image: a file (PNG, ...) or an (H, W, 3|4) array (uint8
        levels, or float display values in [0, 1]); the camera's size.
    scene : Scene
        What the image shows (no textures, mesh colours, bump maps, mirrors
        or shadows: refused with the feature named).
    method : {"flat", "gouraud", "phong"}
        The method the student was asked to implement.
    camera : Camera, optional
        Overrides ``scene.camera``.
    encoding : {"srgb", "linear", "auto"}
        The encoding a correct image has: sRGB (what our ``frame.save``
        writes), linear values, or ``"auto"`` (either counts as correct).
    tolerance : float
        Levels^2 summed over the interior: candidates whose images differ by
        less are reported as one class.

    Returns
    -------
    Diagnosis

    Raises
    ------
    ValueError
        Unknown method or encoding, a scene feature not modelled, nothing of
        the scene in view, an image of the wrong size, blank, out of range (a
        float image outside [0, 1]), or not an image.
    """
    scene, cam = _check_scene_camera(scene, camera)
    student = read_student(image, (cam.height, cam.width))  # refused before anything renders
    return Diagnoser(scene, method, camera=camera, encoding=encoding, tolerance=tolerance)._score(student)


def register_cli(subparsers):
    """Add the ``diagnose`` command to the ``raycast-shade`` parser; dispatch to :func:`run_cli`."""
    import argparse

    p = subparsers.add_parser(
        "diagnose", help="say which lecture choice or common mistake explains a student's image",
        description="Compare a student's 8-bit image of a TOML scene with our renderer and with every candidate "
                    "mistake of the catalogue (docs/diagnose.md); print the verdict, the lowest scores and our "
                    "derivation of one pixel.",
        epilog="examples:\n"
               "  raycast-shade diagnose scene.toml student.png --method gouraud\n"
               "  raycast-shade diagnose scene.toml student.png --encoding auto --map departure.png",
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("scene", metavar="SCENE.toml", help="scene file (its camera gives the image size)")
    p.add_argument("image", metavar="IMAGE", help="the student's image (PNG, JPEG, ...)")
    p.add_argument("--method", choices=("flat", "gouraud", "phong"), default=None,
                   help="the method the student was asked for (default: the scene file's shading, else phong)")
    p.add_argument("--encoding", choices=("srgb", "linear", "auto"), default="srgb",
                   help="the encoding a correct image has (default: srgb)")
    p.add_argument("--map", metavar="PATH", default=None,
                   help="write the per-pixel departure from the best explanation as an 8-bit PNG (x8 levels)")


def _check_map_path(path) -> str:
    """``--map``'s path if a PNG can be written there: a ``.png`` name, not a folder, in a writable folder.

    Raises
    ------
    ValueError
        Naming ``--map``: an empty path, another extension (the map is written
        as PNG whatever the name), or a path that cannot be written
        (:func:`~raycast_shade.output.imagefile.check_output_file`).
    """
    from ..output.imagefile import check_output_file

    if not path:
        raise ValueError("--map: expected a file name, got an empty path")
    path = check_output_file(path, "--map")  # first: "is a folder" says more than "not .png"
    if os.path.splitext(path)[1].lower() != ".png":
        raise ValueError(f"--map: {path!r}: the departure map is written as PNG; give a path ending in .png")
    return path


def run_cli(ns) -> int:
    """Run ``raycast-shade diagnose``; errors are raised for the caller to print on one line."""
    from ..scene.scenefile import load_for_render

    if not os.path.isfile(ns.image):
        raise ValueError(f"image {ns.image!r}: no such file")
    if ns.map is not None:  # before the scene loads or anything renders; '' included
        _check_map_path(ns.map)
    scene, render_kwargs, _ = load_for_render(ns.scene)
    method = ns.method or render_kwargs.get("shading", "phong")
    if method not in ("flat", "gouraud", "phong"):
        raise ValueError(f"{ns.scene}: shading {method!r} is not one method; pass --method flat|gouraud|phong")
    result = diagnose(ns.image, scene, method, encoding=ns.encoding)
    print(result)
    if ns.map is not None:
        from ..output.imagefile import write_png

        m = np.nan_to_num(result.map, nan=0.0)
        grey = np.clip(np.rint(m * 8.0), 0, 255).astype(np.uint8)
        write_png(ns.map, np.repeat(grey[:, :, None], 3, axis=2))
    return 0
