"""Helpers compiled for compiled callers only: no Python entry point to build.

Numba builds every compiled function a CPython wrapper (unboxing each argument from its
Python object: for a helper given tuples of arrays and records, more code than the helper's
own) and a C-callable wrapper, lowers both, optimises them and emits their machine code. A
helper that the kernels inline (``forceinline``) is never entered through either: on the
demo's first picture from an empty kernel cache the two wrappers of the inline helpers cost
a fifth of the compile CPU (51.4 -> 41.0 s and 55.7 -> 44.5 s, side by side, 2026-12-05, 2-core
AVX2 machine; see the CHANGELOG). :func:`inline_jit` compiles a helper without them.

A helper's build is only ever linked into its callers' modules, as LLVM IR: nothing runs
its own machine code. So its code library (:class:`_LinkOnlyLibrary`) is never handed to the
JIT engine (no machine code emitted for it), and its module is not optimised on its own: each
caller optimises the linked whole (a helper's module holds every helper it calls, so optimising
each level re-optimised the same code once per level). Its disk-cache entry keeps that IR
(:class:`_LinkOnlyCache`), so a process compiling a new kernel reads the helpers it links
instead of building them; a kernel's entry holds its machine code with its helpers in it, so a
warm process loads kernels and never reads a helper. On the demo's first picture from an empty
cache this saved 12-16% of the CPU (back to back, loaded machine; see the CHANGELOG). The kernels'
machine code changes with it (and with it where LLVM fuses a multiply and an add): arithmetic that
two paths must round alike is fused explicitly (``shading.mirror_rays._fused``).

A Python call of such a helper (the tests and benchmarks make some) still works:
it runs a twin of the same function compiled with its wrappers (:meth:`InlineDispatcher.python`),
cached on disk under a name of its own, so the wrapperless build is never entered from Python.
"""

from __future__ import annotations

import threading
import types

import numba
from llvmlite import binding as ll
from numba.core import codegen as _codegen
from numba.core.caching import CompileResultCacheImpl, FunctionCache
from numba.core.compiler import CompileResult, Compiler
from numba.core.registry import CPUDispatcher

from . import frontend  # noqa: F401 - Numba's front end, cheaper (before any compile)
from . import overloads  # noqa: F401 - one build per overload and inherited flags (before any compile)

__all__ = ["inline_jit", "InlineDispatcher", "TWIN_SUFFIX", "NO_ANNOTATION", "overload_jit"]

# The twin's qualified name: its disk-cache entries are not the helper's (Numba keys them on the
# name, not on the flags).
TWIN_SUFFIX = "__from_python"
_NO_WRAPPERS = {"no_cpython_wrapper": True, "no_cfunc_wrapper": True, "nopython": True}


class _NoEnv:
    """The codegen a helper's library shows Numba's ``get_executable``: setting the
    environment's address is a no-op (the helper's module never reaches the engine)."""

    def __init__(self, codegen):
        self._codegen = codegen

    def set_env(self, env_name, env):
        pass

    def __getattr__(self, name):
        return getattr(self._codegen, name)


class _LinkOnlyLibrary(_codegen.JITCodeLibrary):
    """A helper's code library: LLVM IR for its callers to link and optimise, never machine code."""

    @property
    def codegen(self):
        return _NoEnv(self._codegen)

    # Whether the helper's module is optimised on its own before its callers link it. False: each
    # caller optimises the linked whole, so optimising every level alone re-optimised the same code
    # once per level. It changes the kernels' code (and where LLVM contracts a multiply and an add)
    # against Numba's way (True), yet every golden image holds on AVX2 and on AVX-512 (checked on
    # both; see the CHANGELOG).
    optimise_alone = False

    def _optimize_final_module(self):
        if self.optimise_alone:
            super()._optimize_final_module()

    def _finalize_final_module(self):
        # Numba's, less handing the module to the engine (which emits its machine code).
        self._finalize_dynamic_globals()
        self._verify_declare_only_symbols()
        self._finalized = True

    def get_pointer_to_function(self, name):
        self._ensure_finalized()
        return 0

    def serialize_using_object_code(self):
        # What the disk cache keeps (Numba keeps machine code and IR): the IR callers link.
        return self.name, "bitcode", self._get_module_for_linking().as_bitcode()


# What a helper's disk-cache entry keeps in place of its annotated source (``inspect_types``).
NO_ANNOTATION = "(not kept: a helper's disk-cache entry holds its IR; see raycast_shade.common.inline)"


class _LinkOnlyCacheImpl(CompileResultCacheImpl):
    """Numba's disk cache of compile results, rebuilding a helper's into a :class:`_LinkOnlyLibrary`.

    An entry keeps what Numba's keeps but the annotated source that ``inspect_types`` prints, which
    no one asks of a helper (Python calls run its twin): writing it took 1.2% of the CPU of the
    demo's flat first picture from an empty cache, for 84 helpers."""

    def reduce(self, cres):
        # Numba's CompileResult._reduce (0.68) with NO_ANNOTATION for the annotated source.
        libdata = cres.library.serialize_using_object_code()
        fndesc = cres.fndesc
        fndesc.typemap = fndesc.calltypes = None  # (as Numba: not needed, and may not pickle)
        envs = cres._find_referenced_environments()
        return (libdata, fndesc, cres.environment, cres.signature, cres.objectmode, cres.lifted, NO_ANNOTATION,
                cres.reload_init, tuple(envs))

    def rebuild(self, target_context, payload):
        libdata, fndesc, env, signature, objectmode, lifted, typeann, reload_init, _envs = payload
        for fn in reload_init or ():
            fn()
        name, kind, data = libdata
        if kind == "object":  # written before helpers were link-only: its IR for linking is kept beside
            data = data[1]
        library = _LinkOnlyLibrary(target_context.codegen(), name)
        library._final_module = ll.parse_bitcode(data)
        library._finalize_final_module()
        return CompileResult(target_context=target_context, typing_context=target_context.typing_context,
                             library=library, environment=env,
                             entry_point=target_context.get_executable(library, fndesc, env), fndesc=fndesc,
                             type_annotation=typeann, signature=signature, objectmode=objectmode, lifted=lifted,
                             typing_error=None, call_helper=None, metadata=None, reload_init=reload_init,
                             referenced_envs=_envs)


class _LinkOnlyCache(FunctionCache):
    _impl_class = _LinkOnlyCacheImpl


class _LinkOnlyCompiler(Compiler):
    """Numba's pipeline, lowering into a :attr:`library_class` (a :class:`_LinkOnlyLibrary`)."""

    library_class = _LinkOnlyLibrary

    def compile_extra(self, func):
        if self.state.library is None:
            self.state.library = self.library_class(self.state.targetctx.codegen(), func.__qualname__)
        return super().compile_extra(func)


class _OverloadLibrary(_LinkOnlyLibrary):
    """A Numba overload's code library (``np.empty``, ``min``, ...): optimised on its own as Numba
    optimises it (its callers link the IR they always linked), no machine code."""

    optimise_alone = True


class _OverloadCompiler(_LinkOnlyCompiler):
    """Numba's pipeline, lowering into an :class:`_OverloadLibrary`."""

    library_class = _OverloadLibrary


def overload_jit(**options):
    """``numba.jit(**options)`` for the implementation of a Numba ``@overload`` (``np.empty``,
    ``min``, array methods, ...; :func:`.overloads.install_jitter`): no C wrapper, no machine code.

    Numba builds each such implementation a C wrapper and emits its machine code (and that of the
    wrapper), yet only compiled callers call it, linking its LLVM IR; 45 of them are built for the
    demo's flat first picture. The IR they link is Numba's own (optimised alone, as before), so the
    callers' code is unchanged. An implementation asked for a disk cache or a pipeline of its own
    keeps Numba's way.

    Returns
    -------
    callable
        The decorator.
    """
    if options.get("cache") or options.get("pipeline_class") is not None:
        return numba.jit(**options)
    return numba.jit(pipeline_class=_OverloadCompiler, **dict(options, no_cfunc_wrapper=True))


class InlineDispatcher(CPUDispatcher):
    """A dispatcher whose builds have no CPython or C wrapper (see the module's notes).

    Compiled callers use its builds as any dispatcher's. None of them is registered as a Python
    entry point, so a call from Python reaches :meth:`_compile_for_args`, which hands the call to
    :meth:`python`'s twin.
    """

    _twin_lock = threading.Lock()

    def enable_caching(self):
        self._cache = _LinkOnlyCache(self.py_func)

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
                    twin = self._twin = numba.njit(cache=getattr(self, "_twin_cache", True), **opts)(g)
        return twin


def inline_jit(*, cache: bool = True, **options):
    """``njit(**options)`` for a helper that only compiled code calls: no CPython or C
    wrapper (:class:`InlineDispatcher`), no machine code; its disk cache keeps LLVM IR (see
    the module's notes). Takes the flags of ``njit`` (``forceinline``, ``_nrt``, ``fastmath``,
    ``cache``, ...).

    Returns
    -------
    callable
        The decorator: ``@inline_jit(**HELPER)`` above a ``def``, or ``inline_jit(**HELPER)(f)``.
    """

    def decorate(func):
        target = dict(options, **_NO_WRAPPERS)
        disp = InlineDispatcher(py_func=func, targetoptions=target, pipeline_class=_LinkOnlyCompiler)
        disp._twin_cache = cache
        if cache:
            disp.enable_caching()
        return disp

    return decorate


overloads.install_jitter(overload_jit)


_WRAPPER_MODULES = ("wrapper", "cfunc_wrapper")  # the names Numba 0.68 gives a wrapper's IR module


def install_wrapper_passes() -> bool:
    """Leave a kernel's CPython and C wrappers to the module passes that optimise the linked whole.

    Numba runs LLVM's function passes on each IR module it adds to a library before linking it,
    the wrappers' included: a wrapper unboxes every argument from its Python object, for our
    kernels' records of arrays thousands of lines, and optimising them alone took 2-3% of a cold
    start's CPU. The library's module passes (``O3``) optimise the linked module, wrappers and
    all, anyway. The kernels' own functions are what they were (their optimised IR compared equal
    on the whole demo, 2026-12-06, Numba 0.68).

    Returns
    -------
    bool
        Whether it is installed (only for the Numba versions checked).
    """
    def make(numbas):
        def _optimize_functions(self, ll_module):
            if ll_module.name in _WRAPPER_MODULES:
                ll_module.data_layout = self._codegen._data_layout  # what Numba's sets first
                return
            numbas(self, ll_module)
        return _optimize_functions

    return frontend.replace(_codegen.CPUCodeLibrary, "_optimize_functions", make)


WRAPPER_PASSES = install_wrapper_passes()
