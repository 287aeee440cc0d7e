"""Helpers compiled for compiled callers only: no Python entry point to build.

Numba builds every compiled function a CPython wrapper (unboxing each argument from its
Python object: for a helper given tuples of arrays and records, more code than the helper's
own) and a C-callable wrapper, lowers both, optimises them and emits their machine code. A
helper that the kernels inline (``forceinline``) is never entered through either: on the
demo's first picture from an empty kernel cache the two wrappers of the inline helpers cost
a fifth of the compile CPU (51.4 -> 41.0 s and 55.7 -> 44.5 s, side by side, 2026-12-05, 2-core
AVX2 machine; see the CHANGELOG). :func:`inline_jit` compiles a helper without them.

A Python call of such a helper (the tests and benchmarks make some) still works:
it runs a twin of the same function compiled with its wrappers (:meth:`InlineDispatcher.python`),
cached on disk under a name of its own, so the wrapperless build is never entered from Python.
"""

from __future__ import annotations

import threading
import types

import numba
from numba.core.caching import NullCache
from numba.core.registry import CPUDispatcher

__all__ = ["inline_jit", "InlineDispatcher", "TWIN_SUFFIX"]

# The twin's qualified name: its disk-cache entries are not the helper's (Numba keys them on the
# name, not on the flags).
TWIN_SUFFIX = "__from_python"
_NO_WRAPPERS = {"no_cpython_wrapper": True, "no_cfunc_wrapper": True, "nopython": True}


class InlineDispatcher(CPUDispatcher):
    """A dispatcher whose builds have no CPython or C wrapper (see the module's notes).

    Compiled callers use its builds as any dispatcher's. None of them is registered as a Python
    entry point, so a call from Python reaches :meth:`_compile_for_args`, which hands the call to
    :meth:`python`'s twin.
    """

    _twin_lock = threading.Lock()

    def add_overload(self, cres):
        # Kept for compiled callers (and their inlining); no Python entry point: it has no wrapper.
        self.overloads[tuple(cres.signature.args)] = cres

    def _compile_for_args(self, *args, **kws):
        # Numba's C dispatcher calls what this returns with the call's arguments.
        return self.python()

    def python(self):
        """The twin compiled with wrappers, for calls from Python (made on first use)."""
        twin = getattr(self, "_twin", None)
        if twin is None:
            with self._twin_lock:
                twin = getattr(self, "_twin", None)
                if twin is None:
                    f = self.py_func
                    g = types.FunctionType(f.__code__, f.__globals__, f.__name__, f.__defaults__, f.__closure__)
                    g.__qualname__ = f.__qualname__ + TWIN_SUFFIX
                    g.__module__, g.__doc__ = f.__module__, f.__doc__
                    opts = {k: v for k, v in self.targetoptions.items() if k not in _NO_WRAPPERS}
                    twin = self._twin = numba.njit(cache=not isinstance(self._cache, NullCache), **opts)(g)
        return twin


def inline_jit(*, cache: bool = True, **options):
    """``njit(**options)`` for a helper that only compiled code calls: no CPython or C
    wrapper (:class:`InlineDispatcher`). Takes the flags of ``njit`` (``forceinline``,
    ``_nrt``, ``fastmath``, ...).

    Returns
    -------
    callable
        The decorator: ``@inline_jit(**HELPER)`` above a ``def``, or ``inline_jit(**HELPER)(f)``.
    """

    def decorate(func):
        target = dict(options, **_NO_WRAPPERS)
        disp = InlineDispatcher(py_func=func, targetoptions=target)
        if cache:
            disp.enable_caching()
        return disp

    return decorate
