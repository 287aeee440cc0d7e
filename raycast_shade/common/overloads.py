"""One build of each Numba overload per set of flags it inherits, not per caller's flags.

Numba keeps the implementation it builds for an ``@overload`` (``min``, ``max``, ``np.empty``,
array indexing, ...) under the argument types and the *whole* ``Flags`` of the function being
compiled. Our kernels and helpers differ in flags no overload sees (``no_cpython_wrapper``,
``no_cfunc_wrapper``, ``release_gil``, ``enable_looplift``, ``no_compile`` for type-only passes),
so the same implementation was built and compiled again for each caller kind (``np.empty`` for
``(int64, uint32)`` twice, scalar ``max`` of two ``int64`` four times on the demo's flat first
picture; 1,294 overload builds there, 1,213 with the key below). An overload's
build inherits only ``nrt``, ``fastmath``, ``error_model`` and ``forceinline`` from its caller
(``CPUTargetOptions.finalize``); its other flags are its own. :func:`install` keys the cache on
those four, so callers that would get the same build share it: the code each kernel links is
what it was.

Comparing whole ``Flags`` was itself a cost: their hash covers only the option names, so each
look-up compared the flags of every build of the same types, option by option (about 48,000
comparisons on the demo's first picture).

The overloads that only allocate and zero arrays (``np.empty``, ``np.zeros``, ...: ``_FLAG_FREE``)
are keyed on ``nrt`` and ``forceinline`` alone: their code has nothing fast-math or the error model
changes, and the kernels (fast-math, NumPy's error model) and the visibility code (neither) asked
for the same arrays (7 of the flat first picture's 45 overload builds were such twins).
:func:`install_jitter` builds every overload without a C wrapper or machine code
(:func:`~raycast_shade.common.inline.overload_jit`).
"""

from __future__ import annotations

import numba
from numba.core import targetconfig, types
from numba.core.typing import templates
from numba.cpython import builtins
from numba.np import arrayobj

__all__ = ["install", "install_jitter", "INHERITED"]

# The flags an overload's build takes from the function being compiled (Numba 0.68's
# CPUTargetOptions.finalize); every other flag of the build is set by the overload itself.
INHERITED = ("nrt", "fastmath", "error_model", "forceinline")
_CHECKED = ("0.68",)


def _inherited(flags):
    if flags is None:
        return None
    fm = flags.fastmath
    return flags.nrt, frozenset(fm.flags) if fm else frozenset(), flags.error_model, flags.forceinline


# Overloads whose build does not depend on the caller's fast-math flags or error model: they
# allocate and zero arrays, with integer arithmetic only (no float instruction to carry fast-math
# flags, no division whose divisor is not a constant). Their builds for the kernels (fast-math, the
# NumPy error model) and for the visibility code (neither) were built twice and compared equal,
# optimised IR against optimised IR (2026-12-06, Numba 0.68): they are built once per NRT and
# forceinline setting.
_FLAG_FREE = frozenset(getattr(arrayobj, name, None) for name in (
    "ol_np_empty", "ol_np_zeros", "ol_array_zero_fill", "ol_compatible_view")) - {None}


# Overloads whose build has no instruction that fast-math flags or the error model change: ``min``
# and ``max`` of integers (comparisons and selects), ``int`` of a number (one conversion, which
# carries no fast-math flags). They too are built once per NRT and forceinline setting (the flat
# first picture built ``max`` of two int64 four times, ``min`` three times and ``int`` of a float64
# twice, for callers whose fast-math flags and error models differ; optimised IR compared equal,
# 2026-12-06, Numba 0.68).
_ON_INTEGERS = frozenset(getattr(builtins, name, None) for name in ("ol_min", "ol_max")) - {None}
_ON_NUMBERS = frozenset([getattr(builtins, "ol_int", None)]) - {None}


def _of(kinds, args) -> bool:
    return all(isinstance(a, kinds) or (isinstance(a, types.BaseTuple) and _of(kinds, a.types)) for a in args)


def _flag_free(func, args, kws) -> bool:
    """Whether overload ``func``'s build for ``args`` is the same whatever fast-math flags and error
    model its caller has."""
    if func in _FLAG_FREE:
        return True
    if kws:
        return False
    return (func in _ON_INTEGERS and _of(types.Integer, args)) or (
        func in _ON_NUMBERS and _of((types.Integer, types.Float, types.Boolean), args))


def _get_impl(self, args, kws):
    # Numba's _OverloadFunctionTemplate._get_impl, keyed on the inherited flags only.
    flags = _inherited(targetconfig.ConfigStack.top_or_none())
    if flags is not None and _flag_free(self._overload_func, args, kws):
        flags = flags[0], flags[3]
    cache_key = self.context, tuple(args), tuple(kws.items()), flags
    try:
        return self._impl_cache[cache_key]
    except KeyError:
        pass
    return self._build_impl(cache_key, args, kws)


def install() -> bool:
    """Key Numba's overload cache on the inherited flags (only for the Numba versions whose
    flag inheritance was checked; others keep Numba's own key).

    Returns
    -------
    bool
        Whether the key is ours.
    """
    cls = templates._OverloadFunctionTemplate
    if cls._get_impl is _get_impl:
        return True
    if not numba.__version__.startswith(_CHECKED):
        return False
    cls._get_impl = _get_impl
    return True


def install_jitter(jitter) -> bool:
    """Build every CPU overload's implementation with ``jitter`` (a ``numba.jit``-like decorator
    factory, :func:`~raycast_shade.common.inline.overload_jit`) instead of ``numba.jit``: other
    targets' keep theirs. Only for the Numba versions checked, as :func:`install`.

    Returns
    -------
    bool
        Whether ``jitter`` is installed.
    """
    cls = templates._OverloadFunctionTemplate
    if not numba.__version__.startswith(_CHECKED):
        return False
    numbas = getattr(cls, "_numbas_jit_decorator", cls._get_jit_decorator)  # installed once

    def _get_jit_decorator(self):
        found = numbas(self)
        return jitter if found is numba.jit else found

    cls._numbas_jit_decorator = numbas
    cls._get_jit_decorator = _get_jit_decorator
    return True


INSTALLED = install()
