"""The batched Phong kernel's scratch: :data:`LANES` lanes of float64 fields, structure of arrays.

A module of its own so that the kernel (:mod:`.phong_fast`) and the passes that make the lanes'
mirror rays (:mod:`.mirror_rays`, for the kernel and the mirror kernel) share the layout without
importing each other.
"""

from __future__ import annotations

from numba import types
from numba.extending import intrinsic

__all__ = ["LANES"]

LANES = 64  # pixels shaded together: 64 lanes of 54 float64 fields (27 KiB) stay in the L1 cache
# Fields of the scratch array, each LANES wide: field F of lane k is S[F * LANES + k].
(_P, _A, _FN, _KA, _KD, _KS, _KE, _SHN, _SHT, _MODEL, _HASSPEC, _V, _G, _N, _R, _S, _D, _ATT, _ND, _LIT, _CP,
 _CB, _CC, _PW) = (0, 3, 6, 9, 12, 15, 18, 21, 22, 23, 24, 25, 28, 31, 34, 37, 40, 41, 42, 43, 44, 45, 46, 47)
# Fields 48-53 serve one of two builds that never meet (terms are not traced with shadows here):
# the barycentrics (every build's until the gather), the sign that turned the geometric normal and
# shadowed frames' shadow origin; the terms build's diffuse and specular terms, summed by the
# accumulate pass (zeroed after the gather).
_B1, _B2, _SG, _O = 48, 49, 50, 51
_TD, _TS = 48, 51
_FIELDS = 54


@intrinsic
def _pick(typingctx, cond, a, b):
    """``a if cond else b`` as one LLVM ``select``, for the batched kernel's passes over the lanes.

    Numba compiles a conditional expression to branches; LLVM then sinks the work of the side
    not always taken (its scratch loads) into its branch, and the vectoriser turns those loads into
    masked loads (``vmaskmovpd``), slow on this machine. Both sides here are computed anyway, in
    the same block: the same values, so the same bits, with plain loads and a blend."""
    if not (isinstance(cond, types.Boolean) and isinstance(a, types.Float) and a == b):
        return None

    def codegen(context, builder, signature, args):
        return builder.select(args[0], args[1], args[2])

    return a(cond, a, b), codegen
