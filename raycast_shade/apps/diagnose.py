"""Diagnose a student's image: which choice of the lecture, or which slip, explains it.

:func:`diagnose` renders the scene with our renderer, re-shades the same hit
buffer with every candidate of the catalogue
(:mod:`raycast_shade.study.diagnose.catalogue`, each a switch of the variant
shader :mod:`raycast_shade.study.diagnose.variant`), scores each against the
student's 8-bit image on the interior pixels the scene covers (the
background is not scored, and the verdict says so), and names the best only
when it holds everywhere under a stated noise model, region by region, and
beats the correct image by a margin the noise justifies
(:mod:`raycast_shade.study.diagnose.holds`); otherwise it says "cannot tell"
and why, or "not a render of this scene". With a per-pixel departure map and
a verdict that points to one pixel and prints our ``explain()`` beside the
student's number. See ``docs/diagnose.md``.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field, replace

import numpy as np

from ..common.validate import as_bool, as_choice, as_instance, as_scalar
from ..render import render
from ..scene.pitfalls import outside_view
from ..study.diagnose.catalogue import catalogue
from ..study.diagnose.holds import (FAR, FOREIGN_SHARE, PIXEL_TOL, REGION_MEDIAN, REGION_SHARE, SIGMA, VISIBLE,
                                    LEAN, REGION_MIN, VOTE, VOTE_SHARE, departure, foreign_share, holds, justified,
                                    margin, regions)
from ..study.diagnose.score import fitted_image, interior_weights, read_student, sse, sse_filtered
from ..study.diagnose.variant import Mistake, check_scene, decode, encode, gather, shade_variant
from ..visibility.cast import cast_camera

__all__ = ["diagnose", "Diagnoser", "Diagnosis", "TOLERANCE", "FIT", "STATUSES", "register_cli", "run_cli"]

TOLERANCE = 100.0  # levels^2, summed over interior pixels and channels: candidates closer than this are one class
FIT = 6.0  # levels RMS: a guide only; verdicts need the per-region test of study/diagnose/holds.py
REFIT = 6  # candidates re-scored with a fitted sub-pixel shift and blur (score.sse_filtered)
BETWEEN = 0.4  # excess / distance below which an image is between two candidates (see Diagnoser._score)
_NOTHING_IN_VIEW = ("scene: nothing of the scene is in view of the camera (no pixel sees a model: behind the camera, "
                    "or outside its view?); diagnose cannot tell anything from the image")


STATUSES = ("matches", "explained", "cannot-tell", "not-a-render")


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
        the interior pixels its own frame covers (lower is better).
    best : Candidate
        The explanation (a correct one when the image matches): the simplest
        candidate (catalogue order) of those indistinguishable from the
        lowest-scoring one. Under ``"cannot-tell"`` and ``"not-a-render"``
        only the closest candidate, which does *not* explain the image.
    group : tuple of str
        The class of the lowest-scoring candidate: candidates whose images
        differ from its by less than the tolerance on this scene
        (indistinguishable here), and those the image lies between (its
        squared error exceeds the best's by less than ``BETWEEN`` times the
        squared distance between the two: at least 30% of the way over).
    matches : bool
        ``status == "matches"``.
    explained : bool
        ``status`` is ``"matches"`` or ``"explained"``: a verdict was given.
    map : (H, W) float32
        Per pixel, the largest channel's absolute difference between the
        image and the best candidate, in levels; NaN where not scored
        (silhouettes, and the background: pixels the scene does not cover).
    weights : (H, W) float64
        1 on the pixels that were scored for the best candidate, 0 elsewhere.
    pixel : (x, y)
        The pixel the verdict points to.
    verdict : str
        A few sentences.
    explanation : str
        Our ``frame.explain(x, y)`` printout at ``pixel``.
    status : {"matches", "explained", "cannot-tell", "not-a-render"}
        A correct image; a slip named; no verdict (the reason in ``verdict``);
        an image that is not a render of this scene.
    facts : dict
        The numbers behind the status (:func:`~raycast_shade.study.diagnose.holds.holds`'s,
        plus ``foreign`` (share of pixels far from every candidate),
        ``background`` and ``silhouette`` (pixels not scored), ``advantage``
        and ``margin`` (levels^2) when a slip was weighed against correct).
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
    status: str = "matches"
    facts: dict = field(default_factory=dict, repr=False)

    def ranking(self, n: int = 5) -> list:
        """The ``n`` lowest-scoring candidates as (name, RMS) pairs."""
        return sorted(self.scores.items(), key=lambda kv: kv[1])[:n]

    def __str__(self) -> str:
        lines = [self.verdict, "", "lowest scores (RMS, 8-bit levels):"]
        lines += [f"  {name:<40s} {rms:8.3f}" for name, rms in self.ranking()]
        lines += ["", self.explanation]
        return "\n".join(lines)

    def __repr__(self) -> str:
        return (f"Diagnosis(status={self.status!r}, best={self.best.name!r}, "
                f"rms={self.scores[self.best.name]:.3g})")

    def _repr_html_(self) -> str:
        import html

        rows = "".join(f"<tr><td>{html.escape(n)}</td><td>{r:.3f}</td></tr>" for n, r in self.ranking(8))
        return (f"<p><b>{html.escape(self.verdict)}</b></p><table><tr><th>candidate</th><th>RMS (levels)</th></tr>"
                f"{rows}</table><pre>{html.escape(self.explanation)}</pre>")


def _fmt(rgb) -> str:
    return "(" + ", ".join(f"{x:.4g}" for x in rgb) + ")"


def _pick_pixel(student, best_img, correct_img, usable):
    """The usable pixel where the best explanation departs most from the correct image
    and the student agrees with it (the correct image's worst pixel when they are one)."""
    sig = np.abs(best_img - correct_img).sum(axis=2) - np.abs(student - best_img).sum(axis=2)
    if not np.any(np.abs(best_img - correct_img)[usable] > 0.5):
        sig = np.abs(student - correct_img).sum(axis=2)
    sig = np.where(usable, sig, -np.inf)
    y, x = np.unravel_index(int(np.argmax(sig)), sig.shape)
    return int(x), int(y)


_MODEL = ("noise model: 8-bit rounding (+-0.5 level) after the encoding, plus {s:g} levels per channel of the "
          "student's own renderer")


def _head(status, best, rms, facts, method):
    """The verdict's first sentences for ``status``."""
    within = (f"within the noise model everywhere: 99th percentile of the per-pixel departure "
              f"{facts['q99']:.1f} levels <= {PIXEL_TOL:g}, every region's median <= {REGION_MEDIAN:g}; the "
              f"{_MODEL.format(s=SIGMA)}")
    if status == "matches":
        return f"Matches our {method} shading (RMS {rms:.2f} levels on the scored pixels, {within})." + (
            f" The image leans to a slip that changes fewer than {REGION_MIN} pixels by {VOTE:g} levels: too "
            "little to name it." if facts.get("too_small") else "")
    if status == "explained":
        return (f"Best explained by '{best.name}': {best.text} [slide: {best.slide}] (RMS {rms:.2f} levels, "
                f"{within}; better than the correct image by {facts['advantage']:.0f} levels^2, the noise "
                f"model asks {facts['margin']:.0f}).")
    if status == "not-a-render":
        return (f"Not a render of this scene: {100 * facts['foreign']:.0f}% of the scored pixels are more than "
                f"{FAR:g} levels from every candidate (the closest, '{best.name}', RMS {rms:.2f} levels).")
    head = f"Cannot tell: the closest candidate is '{best.name}' ({best.text}; RMS {rms:.2f} levels), but "
    if "region" in facts:
        return head + (f"in one region of the image ({facts['region_size']} pixels, one model under one set of "
                       f"lights) its median departure is {facts['region_median']:.1f} levels and "
                       f"{100 * facts['region_over']:.0f}% of its pixels depart by more than {PIXEL_TOL:g} "
                       f"(the {_MODEL.format(s=SIGMA)}, allows a median of {REGION_MEDIAN:g} and "
                       f"{100 * REGION_SHARE:.0f}%): it does not explain the image there.")
    if facts.get("q99", 0.0) > PIXEL_TOL:
        return head + (f"{100 * facts['over']:.1f}% of the scored pixels depart from it by more than "
                       f"{PIXEL_TOL:g} levels (99th percentile {facts['q99']:.1f}; the {_MODEL.format(s=SIGMA)}, "
                       f"allows 1%).")
    if "leans" in facts:
        return head + (f"the image leans to '{facts['leans']}': of the {facts['own']} pixels where that slip changes "
                       f"the correct image by {VOTE:g} levels or more, {100 * facts['vote']:.0f}% are closer to it "
                       f"(noise alone: under {100 * LEAN:.0f}%): a slip the catalogue does not hold, partly like it.")
    if "advantage" not in facts:
        return head + "no pixel of it could be scored."
    if facts["advantage"] < facts["margin"]:
        return head + (f"it is closer than the correct image by only {facts['advantage']:.0f} levels^2, less "
                       f"than the {facts['margin']:.0f} the {_MODEL.format(s=SIGMA)}, asks before naming a slip.")
    return head + (f"of the {facts['own']} pixels where it changes the correct image by {VOTE:g} levels or more "
                   f"(not clipped at white), only {100 * facts['vote']:.0f}% are closer to it than to the correct "
                   f"image ({100 * VOTE_SHARE:.0f}% asked): the image departs from both in another way.")


def _verdict(status, d_best, group, rms, facts, pixel, student, best_img, correct_img, method, ours):
    x, y = pixel
    head = _head(status, d_best, rms, facts, method)
    others = [g for g in group if g != d_best.name]
    if others and status in ("matches", "explained"):
        head += f" Cannot be told apart on this image from: {', '.join(others)}."
    head += (f" Scored: {facts['scored']} pixels the scene covers; not scored: {facts['background']} background "
             f"pixels (the scene does not cover them) and {facts['silhouette']} pixels next to a silhouette.")
    s8 = np.round(student[y, x]).astype(int).tolist()
    c8 = np.round(correct_img[y, x]).astype(int).tolist()
    b8 = np.round(best_img[y, x]).astype(int).tolist()
    where = (f" At pixel ({x}, {y}) the image has {s8} (8-bit), ours has {c8}"
             + ("" if status == "matches" else f", and '{d_best.name}' predicts {b8}") + ".")
    if status in ("matches", "explained") and not d_best.mistake.flip:
        back = decode(student[y, x], d_best.mistake)
        where += (f" Read back through {'its' if status == 'explained' else 'the'} encoding the image's value is "
                  f"I = {_fmt(back)}, beside our I = {_fmt(ours[y, x])}:")
    return head + where + " our derivation follows."


def _footprints(scene, camera, hits, method, gathered, correct, base):
    """(H, W) region ids of our frame (:func:`~raycast_shade.study.diagnose.holds.regions`): one model,
    the lights whose diffuse term visibly shows, the highlight present or not."""
    shown = encode(correct, base) * 255.0

    def visible(part):
        return np.abs(shown - encode(correct - part, base) * 255.0).max(axis=2) >= VISIBLE

    def shade(**changes):
        return shade_variant(scene, camera, hits, method, replace(Mistake(), **changes), gathered)

    dark = shade(light=len(scene.lights), no_ambient=True)  # the emission alone
    lit = [visible(shade(light=i, no_ambient=True, no_specular=True) - dark) for i in range(len(scene.lights))]
    highlight = visible(correct - shade(no_specular=True))
    return regions(np.asarray(hits.geom), lit, highlight)


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
    masks : dict of str to (H, W) bool
        Where each candidate is scored: interior pixels its own frame covers
        (the background excluded).
    regions : (H, W) int32
        The regions of our frame the verdict tests one by one (``-1``: background).
    weights : (H, W) float64
        1 on the interior pixels our frame covers (the correct candidate's mask).
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
        if not camera.distorted and all(outside_view(camera, m.bounds) for m in scene.models):
            raise ValueError(_NOTHING_IN_VIEW)
        self.frame = frame = render(scene, method, camera=camera)
        hits = frame.hits
        label = np.asarray(hits.geom)
        if not np.any(label >= 0):
            raise ValueError(_NOTHING_IN_VIEW)
        half = cast_camera(scene.geometry, camera, offset=(-0.5, -0.5))
        interior = interior_weights([label, label[::-1], np.asarray(half.geom)]) > 0
        # Each candidate is scored where its own frame sees the scene: the background is the
        # student's business (a grey one is no slip), and a flipped image covers other pixels.
        covered = {(False, False): label >= 0, (True, False): label[::-1] >= 0,
                   (False, True): np.asarray(half.geom) >= 0, (True, True): np.asarray(half.geom)[::-1] >= 0}
        self.masks = {c.name: interior & covered[(c.mistake.flip, c.mistake.half_pixel)] for c in cands}
        self.weights = self.masks[cands[0].name].astype(np.float64)
        self._silhouette = int(np.sum(covered[(False, False)] & ~interior))
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
        base = cands[0].mistake
        correct = shaded[replace(base, encoding="srgb", flip=False, bgr=False)]
        self.regions = _footprints(scene, camera, hits, method, gathered[False], correct, base)
        del shaded

    def __call__(self, image) -> Diagnosis:
        """Diagnose one image (a file or an array, as :func:`diagnose` takes)."""
        return self._score(read_student(image, (self.camera.height, self.camera.width)))

    def _sses(self, student):
        """Each candidate's squared error (scaled to the correct candidate's pixel count) and the fitted
        sub-pixel parameters of the re-scored ones."""
        cands, imgs, masks = self.candidates, self.images, self.masks
        n_ref = float(masks[cands[0].name].sum())
        plain, params = {}, {}
        for c in cands:
            k = float(masks[c.name].sum())
            plain[c.name] = sse(student, imgs[c.name], masks[c.name]) * n_ref / k if k else np.inf
        sses = dict(plain)
        if self.filtered:  # the closest few again, allowing the student's own sub-pixel sampling
            for name in sorted(plain, key=plain.get)[:REFIT]:
                k = float(masks[name].sum())
                fitted, par = sse_filtered(student, imgs[name], masks[name].astype(np.float64))
                if fitted * n_ref / k < plain[name]:
                    sses[name], params[name] = fitted * n_ref / k, par
        return plain, sses, params, n_ref

    def _leans(self, student, group, near, facts, ref) -> str:
        """``"matches"``, unless a slip not indistinguishable from the correct image has ``LEAN`` or more of
        its own pixels closer to the image (listed first if the image lies between it and the correct one)."""
        imgs, masks = self.images, self.masks
        for name in list(group) + [c.name for c in self.candidates if c.name not in group]:
            if name in near:
                continue
            ok, vote = justified(student, imgs[name], imgs[ref], masks[ref] & masks[name])
            if vote["own"] >= REGION_MIN and vote["vote"] >= LEAN:
                facts.update(leans=name, own=vote["own"], vote=vote["vote"])
                return "cannot-tell"
        return "matches"

    def _weigh(self, student, low, facts, sses, params) -> str:
        """The status when the best candidate ``low`` is a slip that holds everywhere: ``"explained"`` if it
        beats the correct image by the margin and its own pixels vote for it; ``"matches"`` if it shows too
        little to name and the correct image holds everywhere too; else ``"cannot-tell"``."""
        imgs, masks = self.images, self.masks
        ref = min((c.name for c in self.candidates if c.correct), key=sses.get)  # "auto": either encoding
        both = masks[ref] & masks[low.name]
        facts.update(advantage=sses[ref] - sses[low.name],
                     margin=margin(sse(imgs[ref], imgs[low.name], both), self.tolerance))
        ok, vote = justified(student, imgs[low.name], imgs[ref], both)
        facts.update(vote)
        if facts["advantage"] >= facts["margin"] and ok:
            return "explained"
        if vote["own"] < REGION_MIN:
            fitted = fitted_image(imgs[ref], params[ref]) if ref in params else imgs[ref]
            region = self.regions
            if holds(departure(student, fitted, masks[ref]), region, departure(student, fitted, masks[ref], 0))[0]:
                facts["too_small"] = True
                return "matches"
        return "cannot-tell"

    def _score(self, student) -> Diagnosis:
        """Diagnose ``student`` (H, W, 3) float64 levels, as :func:`read_student` returns them."""
        cands, imgs, masks = self.candidates, self.images, self.masks
        plain, sses, params, n_ref = self._sses(student)
        scores = {k: float(np.sqrt(v / (3.0 * n_ref))) for k, v in sses.items()}
        low = min(cands, key=lambda c: sses[c.name])
        near, group = [], []
        for c in cands:
            dist = sse(imgs[c.name], imgs[low.name], masks[c.name] & masks[low.name])
            if dist < self.tolerance:  # indistinguishable on this scene
                near.append(c.name)
            # The class also holds candidates the image lies between with the best (the unfiltered excess
            # under BETWEEN of their distance: at least 30% of the way over), which noise alone makes
            # unlikely; they can be told apart, not on this image.
            if dist < self.tolerance or plain[c.name] - plain[low.name] < BETWEEN * dist:
                group.append(c.name)
        group = tuple(group)
        fitted = imgs[low.name]
        if low.name in params:
            fitted = fitted_image(imgs[low.name], params[low.name])
        dep = departure(student, fitted, masks[low.name])
        region = self.regions[::-1] if low.mistake.flip else self.regions
        ok, facts = holds(dep, region, departure(student, fitted, masks[low.name], reach=0))
        facts.update(foreign=foreign_share(student, [imgs[c.name] for c in cands], [masks[c.name] for c in cands],
                                           masks[cands[0].name]),
                     background=int(np.sum(np.asarray(self.frame.hits.geom) < 0)), silhouette=self._silhouette)
        correct = next((c for c in cands if c.correct and c.name in near), None)
        best = correct or next((c for c in cands if c.name in near and not c.correct), low)
        if facts["foreign"] >= FOREIGN_SHARE:
            status = "not-a-render"
        elif not ok:
            status = "cannot-tell"
        elif correct is not None:
            status = self._leans(student, group, near, facts, correct.name)
        else:
            status = self._weigh(student, low, facts, sses, params)
            if status == "matches":  # the slip too small to name: the correct image holds, the slip beside it
                best, group = cands[0], (cands[0].name,) + group
        correct_img = imgs[cands[0].name]
        if ok or "pixel" not in facts:
            pixel = _pick_pixel(student, imgs[best.name], correct_img, masks[best.name] & (dep <= PIXEL_TOL))
        else:
            pixel = facts["pixel"]
        facts["scored"] = int(masks[best.name].sum())
        verdict = _verdict(status, best, group, scores[best.name], facts, pixel, student, imgs[best.name],
                           correct_img, self.method, self.frame.image)
        dmap = departure(student, imgs[best.name], masks[best.name]).astype(np.float32)
        return Diagnosis(self.method, cands, scores, best, group, status == "matches",
                         status in ("matches", "explained"), dmap, masks[best.name].astype(np.float64), pixel,
                         verdict, str(self.frame.explain(*pixel)), status, facts)


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
        ``status`` says whether it is a verdict (``"matches"``, ``"explained"``) or not
        (``"cannot-tell"``, ``"not-a-render"``).

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
