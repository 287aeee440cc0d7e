"""How the shading kernels compile: one flag set, and compile-time variants.

The flags are the same for every shading kernel. No nnan/ninf: misses and
degenerate cases must compare as written; the other fast-math flags keep the
arithmetic the golden images were made with.

A scene with no colours or maps needs none of the texture lookups. The kernels
that evaluate the reflectance equation are therefore built by a small factory
per kernel family, ``make(tex_on)``, whose closure constant Numba folds at
compile time: one registry per family (:func:`compile_variants`), two variants,
each cached on disk separately (Numba keys its cache on the closure's values),
and compiled only when a frame first needs it (:func:`variant` picks a frame's).
The other flags of a frame (``spec_on``: some material has a specular term;
``att_on``: some light attenuates) are run-time fields of the lighting record
(:class:`~raycast_shade.shading.records.Lighting`): a branch per light that
costs less than the noise of a frame, where each compile-time flag doubled
every family's compile time. What a frame holds beyond the lecture's models is a
compile-time marker instead, ``L.ext`` (None or True, :data:`.illumination.LEAN`):
each variant compiles one build per value, and a frame compiles only the one it
takes (the lecture's and the demo's frames compile no spot or area light, GGX
model or normal map).

The helpers the kernels share are compiled with :data:`HELPER` (see there),
the few that must stay calls with :data:`CALLED`.
"""

from __future__ import annotations

import numpy as np

__all__ = ["JIT", "HELPER", "CALLED", "FLT32_MAX", "CHUNK", "VARIANT_FLAGS", "compile_variants", "variant"]

# No C wrapper (``no_cfunc_wrapper``): Numba builds one per function for callers that take its
# address (``cfunc``-style, first-class function values); the kernels are called from Python or
# inlined, never so. Building, optimising and emitting it cost 5% of the demo's cold first picture.
JIT = dict(cache=True, error_model="numpy", fastmath={"nsz", "arcp", "contract", "afn", "reassoc"},
           no_cfunc_wrapper=True)
# The helpers the kernels call per pixel. Numba's own inlining (inline="always") re-ran each
# helper's front end at every call site, and the parfor passes then worked on the whole
# inlined body twice: most of the cold start. Instead each helper compiles once, and LLVM
# inlines it (forceinline; the golden images stay bit-identical). Without
# NRT a helper neither takes nor drops a reference on the arrays it is given (atomic
# operations on counters both threads share: 3x slower Phong frames); it borrows the
# caller's arrays and must not allocate (Numba refuses to compile one that does).
HELPER = dict(JIT, forceinline=True, _nrt=False)
# Functions that stay calls (rare fallbacks), or allocate. Both flags explicit: a dispatcher
# without them inherits those of whichever compile first calls it.
CALLED = dict(JIT, forceinline=False, _nrt=True)
FLT32_MAX = float(np.finfo(np.float32).max)  # radiance saturates here instead of becoming inf
CHUNK = 1024  # faces, vertices or secondary rays per parallel task


VARIANT_FLAGS = ("tex_on",)  # a variant's key, in order: fields of the frame's inputs


def compile_variants(make):
    """One kernel family's registry: ``make(tex_on)`` for both values.

    Returns
    -------
    dict of (bool,) to object
        Keyed by ``(tex_on,)`` (:data:`VARIANT_FLAGS`); the dispatchers compile lazily.
    """
    return {(t,): make(t) for t in (False, True)}


def variant(variants, k):
    """The entry of :func:`compile_variants`'s registry for a frame's
    :class:`~raycast_shade.shading.inputs.FrameInputs` ``k``: the untextured variants'
    arithmetic is the untextured renderer's, bit for bit."""
    return variants[tuple(bool(k[flag]) for flag in VARIANT_FLAGS)]
