"""common/overloads.py: one build of an overload per set of flags it inherits, shared by callers
whose flags differ otherwise; callers that differ in an inherited flag still get their own."""

from __future__ import annotations

import numba
import numpy as np
import pytest
from numba.core.typing import templates
from numba.extending import overload

from raycast_shade.common import overloads
from raycast_shade.common.inline import inline_jit


def _make():
    builds = []

    def twice(x):
        raise NotImplementedError

    @overload(twice)
    def _ol_twice(x):
        builds.append(x)

        def impl(x):
            return 2 * x + 1

        return impl

    return twice, builds


def test_the_key_is_installed_on_this_numba():
    assert overloads.INSTALLED
    assert templates._OverloadFunctionTemplate._get_impl is overloads._get_impl


def test_callers_differing_in_flags_the_overload_does_not_inherit_share_one_build():
    twice, builds = _make()

    @numba.njit(cache=False)
    def plain(x):
        return twice(x)

    @numba.njit(cache=False, nogil=True)
    def released(x):
        return twice(x) + 1

    @inline_jit(cache=False)
    def helper(x):
        return twice(x) - 1

    @numba.njit(cache=False)
    def calls_helper(x):
        return helper(x)

    assert plain(3) == 7 and released(3) == 8 and calls_helper(3) == 6
    # Three callers, three different Flags (release_gil, no_cpython_wrapper...), one build for
    # int64 (Numba's own key built it once per caller's flags).
    assert [str(t) for t in builds] == ["int64"]


@pytest.mark.parametrize("options", [{"fastmath": True}, {"error_model": "numpy"}, {"_nrt": False}])
def test_a_caller_differing_in_an_inherited_flag_gets_its_own_build(options):
    twice, builds = _make()

    @numba.njit(cache=False)
    def plain(x):
        return twice(x)

    @numba.njit(cache=False, **options)
    def other(x):
        return twice(x)

    assert plain(2.5) == 6.0 and other(2.5) == 6.0
    assert [str(t) for t in builds] == ["float64", "float64"]


def _builds_of(qualname, run):
    """The argument types of every build of the compiled function ``qualname`` (or of any of a
    tuple of them) while ``run()`` runs."""
    from numba.core import event

    names = (qualname,) if isinstance(qualname, str) else tuple(qualname)
    seen = []

    class _Listener(event.Listener):
        def on_start(self, e):
            disp = e.data.get("dispatcher")
            if disp is not None and disp.py_func.__qualname__ in names:
                seen.append(e.data.get("args"))

        def on_end(self, e):
            pass

    with event.install_listener("numba:compile", _Listener()):
        run()
    return seen


def test_allocating_overloads_are_built_once_for_callers_of_other_fast_math_and_error_model():
    # A shape type (five int64s) and a dtype nothing else in the suite asks np.empty for.
    @numba.njit(cache=False)
    def plain(n):
        return np.empty((n, n, n, n, n), np.uint16).size

    @numba.njit(cache=False, fastmath=True, error_model="numpy")
    def fast(n):
        return np.empty((n, n, n, n, n), np.uint16).size

    def run():
        assert plain(2) == 32 and fast(2) == 32

    assert len(_builds_of("ol_np_empty.<locals>.impl", run)) == 1  # Numba's key: one per caller


def _forget(funcs, kinds):
    """Drop the builds of the overloads ``funcs`` for argument types ``kinds`` from Numba's caches:
    another test in this process may have built them already."""
    def subclasses(cls):
        for sub in cls.__subclasses__():
            yield sub
            yield from subclasses(sub)

    for cls in subclasses(templates._OverloadFunctionTemplate):
        if cls.__dict__.get("_overload_func") is not None and cls._overload_func in funcs:
            for key in [k for k in cls._impl_cache if k[1] in kinds]:
                del cls._impl_cache[key]


def test_integer_min_max_and_int_are_built_once_float_min_max_per_fast_math():
    """``min``/``max`` of integers and ``int`` of a number have no instruction fast-math flags or the
    error model change: one build for both callers; ``max`` of floats keeps a build per flag set."""
    from numba.core import types
    from numba.cpython import builtins

    _forget({builtins.ol_min, builtins.ol_max, builtins.ol_int},
            {(types.uint16, types.uint16), (types.float32,), (types.float32, types.float32)})

    @numba.njit(cache=False)
    def plain(a, b, x, y):
        return max(a, b), min(a, b), int(x), max(x, y)

    @numba.njit(cache=False, fastmath=True, error_model="numpy")
    def fast(a, b, x, y):
        return max(a, b), min(a, b), int(x), max(x, y)

    def run():
        args = (np.uint16(3), np.uint16(9), np.float32(2.5), np.float32(-1.0))
        assert plain(*args) == fast(*args) == (9, 3, 2, 2.5)

    seen = _builds_of(("ol_max.<locals>.impl", "ol_min.<locals>.impl", "ol_int.<locals>.impl"), run)
    kinds = sorted(str(a) for a in seen)
    assert kinds.count("(UniTuple(uint16, 2),)") == 2  # max and min, once each
    assert kinds.count("(float32,)") == 1  # int
    assert kinds.count("(UniTuple(float32, 2),)") == 2  # max of floats: plain and fast-math


def test_overload_builds_have_no_c_wrapper_or_machine_code():
    from raycast_shade.common import inline

    twice, builds = _make()

    @numba.njit(cache=False)
    def calls(x):
        return twice(x)

    assert calls(4) == 9
    ((impl, _),) = [v for k, v in _impl_caches(twice)]
    cres = impl.overloads[(numba.types.int64,)]
    assert isinstance(cres.library, inline._OverloadLibrary)
    names = [f.name for f in cres.library._final_module.functions if not f.is_declaration]
    assert names and not any(n.startswith("cfunc.") for n in names)  # Numba's C wrapper: cfunc.<name>
    assert cres.library.get_pointer_to_function(cres.fndesc.llvm_func_name) == 0  # no machine code


def _impl_caches(func):
    """The ``(key, (dispatcher, args))`` builds of every overload template of ``func``."""
    out = []
    for tmpl in templates._OverloadFunctionTemplate.__subclasses__():
        if getattr(tmpl, "key", None) is func:
            out.extend((k, v) for k, v in tmpl._impl_cache.items() if v[0] is not None)
    return out
