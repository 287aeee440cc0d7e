"""Does an explanation hold everywhere it should? The noise model and the per-region test.

One RMS over the frame lets a slip that shows in one region pass (a
highlight the colour of the surface, one light reversed). A candidate
explains a student's image only when, on the pixels the scene covers, every
part of the image is within the noise model of it:

* **the noise model**, in 8-bit display levels: the student's file rounds to
  the nearest level (+-0.5, :data:`QUANT`) after its own encoding, and its
  renderer adds its own small differences (float32 arithmetic, another sample
  pattern or a JPEG's artefacts) of about :data:`SIGMA` levels per channel,
  independent from pixel to pixel. :data:`PIXEL_TOL` (``QUANT + 5
  SIGMA``) is a departure that noise does not reach. A pixel's departure is
  measured from the range of the candidate's values within one pixel
  (:func:`departure`): where the student's samples or file move values by a
  pixel (anti-aliasing, a JPEG's chroma subsampling, a resize) that is no
  departure;
* **everywhere**: at most ``1 - QUANTILE`` (1%) of the scored pixels depart
  by more than ``PIXEL_TOL`` (the 99th percentile is within it), and in every
  *region* of at least :data:`REGION_MIN` scored pixels the median departure
  (of the plain differences, not the neighbourhood's) is at most
  :data:`REGION_MEDIAN` and at most :data:`REGION_SHARE` of the
  pixels depart by more than ``PIXEL_TOL``. The regions
  (:func:`regions`) are the connected pieces of our frame with one model, one
  set of lights that visibly light it and the highlight present or not: a
  slip in one light's footprint or in the highlights fails its region even
  where the frame's RMS hides it;
* **better than correct by a margin**: between two candidates at squared
  distance ``D`` (levels^2 summed over the scored pixels) the noise moves the
  difference of their squared errors by ``2 SIGMA sqrt(D)`` per standard
  deviation; a slip is named only when it beats the correct image by
  :func:`margin` (``Z`` = 4 such deviations, and at least the tolerance);
* **the slip's own pixels agree**: a slip is named only where it shows: at
  least :data:`REGION_MIN` scored pixels where it changes a channel by
  :data:`VOTE` levels or more (2 ``SIGMA``) that is not clipped at white in
  both the image and the slip (up to the noise: clipped pixels say only "bright"), and at
  :data:`VOTE_SHARE` of them the image is closer to the slip than to the
  correct image (:func:`justified`). A systematic departure of another kind
  (gamma 2.2, a half vector not normalised that saturates like another slip)
  then does not lend its weight to whichever candidate it happens to lean to;
* **a correct image leans to no slip**: "matches" also needs that no slip
  the image lies between (the class of :func:`~raycast_shade.diagnose`) has
  :data:`LEAN` (30%) of its own pixels closer to it (every candidate not
  indistinguishable from the correct one is asked); the model's noise alone
  brings at most 16% of them closer (a 3-level change against 1.5 levels);
* **a render of this scene at all**: when at least :data:`FOREIGN_SHARE` of
  the scored pixels are more than :data:`FAR` levels from *every* candidate,
  the image is not a render of this scene (a photograph, another scene).

Only pixels the scene covers are scored; the background is excluded (a
student's grey background is no slip) and the verdict says so.
"""

from __future__ import annotations

import numpy as np

__all__ = ["QUANT", "SIGMA", "PIXEL_TOL", "QUANTILE", "REGION_MIN", "REGION_MEDIAN", "REGION_SHARE", "FAR",
           "FOREIGN_SHARE", "Z", "VOTE", "VOTE_SHARE", "LEAN", "VISIBLE", "justified", "departure", "regions", "margin", "holds", "foreign_share"]

QUANT = 0.5  # levels: 8-bit rounding
SIGMA = 1.5  # levels per channel: the student's renderer's own differences (float32, sampling, JPEG)
PIXEL_TOL = QUANT + 5.0 * SIGMA  # 8 levels: a departure noise does not reach
QUANTILE = 0.99  # of the scored pixels' departures: within PIXEL_TOL
REGION_MIN = 12  # scored pixels: smaller regions are tested as part of the frame only
REGION_MEDIAN = QUANT + 2.0 * SIGMA  # 3.5 levels: a region's median departure
REGION_SHARE = 0.1  # of a region's pixels at most depart by more than PIXEL_TOL
Z = 4.0  # standard deviations of the noise between two candidates
FAR = 2.0 * PIXEL_TOL  # 16 levels from every candidate: a pixel no candidate explains
FOREIGN_SHARE = 0.5  # of the scored pixels that far: not a render of this scene
VOTE = 2.0 * SIGMA  # levels: a channel change by a slip that noise does not fake at one pixel
VOTE_SHARE = 0.8  # of the slip's own pixels must be closer to it than to the correct image
LEAN = 0.3  # of a slip's own pixels closer to it: the image leans to it (the model's noise alone: <= 16%)
VISIBLE = 2.0  # levels: a light's diffuse term or the highlights visibly present at a pixel


def departure(student, image, mask, reach: int = 1) -> np.ndarray:
    """(H, W) float64: how far each pixel of ``student`` is from ``image`` near it, in levels; NaN off ``mask``.

    Per channel the distance from the student's value to the range of the
    image's values within ``reach`` pixels (a 3 x 3 neighbourhood for 1: a
    value the image holds a pixel away is no departure, so a JPEG's chroma
    subsampling, a resize or a sub-pixel shift at a sharp highlight is not
    held against the image, while a slip over a region still is); the
    largest of the three channels. ``reach=0``: ``max |student - image|``.

    Parameters
    ----------
    student, image : (H, W, 3) float
        Levels 0..255.
    mask : (H, W) bool
    reach : int
    """
    from scipy import ndimage

    student = np.asarray(student, np.float64)
    image = np.asarray(image, np.float64)
    size = (2 * reach + 1, 2 * reach + 1, 1)
    lo = ndimage.minimum_filter(image, size=size, mode="nearest")
    hi = ndimage.maximum_filter(image, size=size, mode="nearest")
    d = np.maximum(lo - student, student - hi).clip(0.0).max(axis=2)
    return np.where(mask, d, np.nan)


def regions(label, lit, highlight) -> np.ndarray:
    """(H, W) int32 region ids (``-1`` on the background): the connected pieces of one signature.

    Parameters
    ----------
    label : (H, W) int
        Model index per pixel, ``-1`` for the background.
    lit : (L, H, W) bool
        Where each light's diffuse term visibly changes our image.
    highlight : (H, W) bool
        Where the specular terms visibly change it.
    """
    from scipy import ndimage

    label = np.asarray(label)
    bits = highlight.astype(np.int64)
    for i, light in enumerate(lit):
        bits = bits + np.asarray(light, np.int64) * 2 ** (i + 1)
    sig = label.astype(np.int64) + 1 + (int(label.max()) + 2) * bits
    sig[label < 0] = -1
    out = np.full(label.shape, -1, np.int32)
    count = 0
    for value in np.unique(sig[sig >= 0]):
        pieces, n = ndimage.label(sig == value)  # 4-connected
        sel = pieces > 0
        out[sel] = pieces[sel] - 1 + count
        count += n
    return out


def margin(distance: float, tolerance: float) -> float:
    """Levels^2 by which a slip must beat the correct image: ``max(tolerance, Z 2 SIGMA sqrt(D))``."""
    return max(float(tolerance), Z * 2.0 * SIGMA * float(np.sqrt(max(distance, 0.0))))


def holds(dep, region, plain=None) -> tuple:
    """Whether the departure map ``dep`` (NaN off the scored pixels) is within the noise model everywhere.

    Parameters
    ----------
    dep : (H, W) float64
        :func:`departure` of the candidate (within one pixel).
    region : (H, W) int
        :func:`regions` in the candidate's pixel grid.
    plain : (H, W) float64, optional
        ``departure(..., reach=0)``: the regions' medians are taken of it
        (a slip over a region moves its median; a pixel's neighbourhood can
        hide a small highlight's colour). Default: ``dep``.

    Returns
    -------
    ok : bool
    facts : dict
        ``q99`` (the 99th percentile), ``over`` (the share over ``PIXEL_TOL``),
        ``scored``; when a region fails, ``region`` (its id), ``region_size``,
        ``region_median``, ``region_over`` and ``pixel`` (x, y: its worst
        pixel); when the frame fails, ``pixel`` is the frame's worst.
    """
    sel = np.isfinite(dep)
    vals = dep[sel]
    facts = dict(scored=int(vals.size), q99=float(np.quantile(vals, QUANTILE)) if vals.size else 0.0,
                 over=float(np.mean(vals > PIXEL_TOL)) if vals.size else 0.0)
    if not vals.size:
        return False, facts
    ok = facts["q99"] <= PIXEL_TOL
    worst = None
    ids = np.where(sel, region, -1)
    for r in np.unique(ids[ids >= 0]):
        here = ids == r
        d = dep[here]
        if d.size < REGION_MIN:
            continue
        med, over = float(np.median((dep if plain is None else plain)[here])), float(np.mean(d > PIXEL_TOL))
        if med > REGION_MEDIAN or over > REGION_SHARE:
            score = (d.size * over, med)  # the region with the most pixels off: the one to show
            if worst is None or score > worst[0]:
                worst = (score, int(r), int(d.size), med, over)
    if worst is not None:
        ok = False
        _, r, size, med, over = worst
        facts.update(region=r, region_size=size, region_median=med, region_over=over)
        pick = np.where(ids == r, dep, -np.inf)
    else:
        pick = np.where(sel, dep, -np.inf)
    y, x = np.unravel_index(int(np.argmax(pick)), pick.shape)
    facts["pixel"] = (int(x), int(y))
    return bool(ok), facts


def foreign_share(student, images, masks, scored) -> float:
    """The share of ``scored`` pixels more than :data:`FAR` levels from every candidate.

    Parameters
    ----------
    student : (H, W, 3) float64
    images : sequence of (H, W, 3)
        The candidates' images, levels.
    masks : sequence of (H, W) bool
        Where each candidate is scored (a candidate counts only there).
    scored : (H, W) bool
    """
    best = np.full(scored.shape, np.inf)
    for img, m in zip(images, masks):
        d = np.abs(student - img).max(axis=2)
        best = np.where(m, np.minimum(best, d), best)
    n = int(scored.sum())
    return float(np.mean(best[scored] > FAR)) if n else 0.0


def justified(student, slip, correct, mask) -> tuple:
    """Whether the pixels where ``slip`` differs from ``correct`` vote for it.

    Parameters
    ----------
    student, slip, correct : (H, W, 3) float
        Levels 0..255 (the slip's and the correct image in the student's grid).
    mask : (H, W) bool
        Scored for both.

    Returns
    -------
    ok : bool
        At least :data:`REGION_MIN` informative pixels (a channel changed by
        :data:`VOTE` levels or more, not clipped at white in both the image
        and the slip) and at least :data:`VOTE_SHARE` of them closer to the
        slip.
    facts : dict
        ``own`` (the informative pixels) and ``vote`` (the share closer to the slip).
    """
    student = np.asarray(student, np.float64)
    changed = np.abs(np.asarray(slip, np.float64) - correct) >= VOTE
    clipped = (np.asarray(slip) >= 254.5) & (student >= 255.0 - VOTE)  # white in both, up to the noise
    own = mask & np.any(changed & ~clipped, axis=2)
    closer = np.square(student - slip).sum(axis=2) < np.square(student - correct).sum(axis=2)
    n = int(own.sum())
    vote = float(np.mean(closer[own])) if n else 0.0
    return bool(n >= REGION_MIN and vote >= VOTE_SHARE), dict(own=n, vote=vote)
