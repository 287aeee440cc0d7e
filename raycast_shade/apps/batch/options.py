"""How every frame of a batch is rendered and written: the options, checked once.

The values go through :func:`raycast_shade.scene.scenefile.check_render_options`,
the checks of a scene file's ``[render]`` table, so a batch accepts what a
scene file, :func:`raycast_shade.render_file` and the command line accept.
Where and how the frames run (workers, retries, ...) is :class:`~raycast_shade.apps.batch.run.RunOptions`.
"""

from __future__ import annotations

import dataclasses
import os
from dataclasses import dataclass

from ...common.validate import as_bool
from ...scene.scenefile import RENDER_KEYS, SIZE_KEYS, TONE_KEYS, check_render_options

__all__ = ["cores", "BatchOptions", "RENDER_KWARGS", "TRANSFERS", "check_options", "check_shading_fits",
           "WINDOW_BYTES"]

# render() keywords a batch passes on; the camera (hence the size) is per frame.
RENDER_KWARGS = tuple(k for k in RENDER_KEYS if k not in ("shading",) + SIZE_KEYS + TONE_KEYS)
# How images return from Dask workers: "disk" through a temporary folder, "dask" through its comms,
# "auto" the folder on a cluster of this machine (see dask_driver).
TRANSFERS = ("auto", "dask", "disk")
WINDOW_BYTES = 256 << 20  # default bound on the images in flight or awaiting their turn


@dataclass(frozen=True, eq=False)
class BatchOptions:
    """How every frame of a batch is rendered and written.

    Attributes
    ----------
    shading : str or tuple of str
        ``"flat"``, ``"gouraud"``, ``"phong"``, ``"auto"``, or one method per
        model.
    render_kwargs : dict
        Extra keywords of :func:`raycast_shade.render` (``backend``,
        ``interpolation``, ``caster``, ``max_depth``, ``tolerance``).
    tone : dict
        Keywords of :func:`raycast_shade.to_uint8` for 8-bit outputs.
    resume : bool
        Skip a frame whose output file exists.
    """

    shading: object = "phong"
    render_kwargs: dict = dataclasses.field(default_factory=dict)
    tone: dict = dataclasses.field(default_factory=dict)
    resume: bool = True


def cores() -> int:
    """Cores this process may run on."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # pragma: no cover - not Linux
        return os.cpu_count() or 1


def check_options(shading, render_kwargs: dict, tone, resume) -> BatchOptions:
    """The validated, normalised options of a batch.

    Raises
    ------
    TypeError
        For an unknown keyword or tone key, or a value of the wrong type.
    ValueError
        For a bad value, naming it.
    """
    for k in render_kwargs:
        if k not in RENDER_KWARGS:
            raise TypeError(f"render_batch: unexpected keyword argument {k!r} (render options: {list(RENDER_KWARGS)})")
    tone = {} if tone is None else tone
    if not isinstance(tone, dict):
        raise TypeError(f"tone: expected a dict of to_uint8 options, got {type(tone).__name__}")
    for k in tone:
        if k not in TONE_KEYS:
            raise TypeError(f"tone: unexpected key {k!r} (expected some of {list(TONE_KEYS)})")
    checked = check_render_options({"shading": shading, **render_kwargs})
    tone = check_render_options(dict(tone))
    resume = as_bool(resume, "resume")
    shading = checked.pop("shading")
    return BatchOptions(shading, checked, tone, resume)


def check_shading_fits(options: BatchOptions, bases: dict) -> None:
    """One method per model must name every model of every mesh set."""
    if isinstance(options.shading, str):
        return
    for base in bases.values():
        if len(options.shading) != len(base.models):
            raise ValueError(f"shading: expected one method per model ({len(base.models)}), "
                             f"got {len(options.shading)}")
