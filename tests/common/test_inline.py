"""Helpers without wrappers (common/inline.py): the same results from compiled callers and
from Python, no CPython wrapper in their builds, no machine code or disk cache of their own,
and no wrapperless build ever entered from Python."""

from __future__ import annotations

import importlib
import os
import subprocess
import sys
import textwrap

import numba
import numpy as np
import pytest
from numba.core.registry import CPUDispatcher

import raycast_shade
from raycast_shade.common.inline import TWIN_SUFFIX, InlineDispatcher, inline_jit


@inline_jit(cache=False, forceinline=True, _nrt=False)
def _axpy(a, i, t):
    return a[i] * t[0] + t[1]


@numba.njit(cache=False)
def _sum_axpy(a):
    s = 0.0
    for i in range(a.shape[0]):
        s += _axpy(a, i, (2.0, 1.0))
    return s


def _wrapper_address(cres):
    return cres.library.get_pointer_to_function(cres.fndesc.llvm_cpython_wrapper_name)


def test_compiled_callers_and_python_get_the_same_values():
    a = np.array([0.5, -1.25, 3.0, 7.75])
    assert _sum_axpy(a) == sum(2.0 * x + 1.0 for x in a)
    for i in range(a.shape[0]):
        assert _axpy(a, i, (2.0, 1.0)) == 2.0 * a[i] + 1.0


def test_the_build_for_compiled_callers_has_no_python_wrapper():
    _sum_axpy(np.ones(3))
    (cres,) = _axpy.overloads.values()
    assert _wrapper_address(cres) == 0
    twin = _axpy.python()
    _axpy(np.ones(3), 0, (1.0, 0.0))
    (tres,) = twin.overloads.values()
    assert _wrapper_address(tres) != 0
    assert twin.py_func.__qualname__ == _axpy.py_func.__qualname__ + TWIN_SUFFIX
    assert _axpy.python() is twin


def test_a_helpers_build_is_ir_for_its_callers_only():
    # No machine code of its own: its module never reaches the JIT engine; its caller's does,
    # with the helper linked in (the values above come from it).
    _sum_axpy(np.ones(3))
    (hres,) = _axpy.overloads.values()
    (kres,) = _sum_axpy.overloads.values()
    modules = kres.library.codegen._engine._ee._modules  # llvmlite's: every module handed to the engine
    assert kres.library._final_module in modules
    assert hres.library._final_module not in modules
    assert hres.library.get_pointer_to_function(hres.fndesc.llvm_func_name) == 0


def test_a_python_call_with_wrong_arguments_raises_as_numba_does():
    with pytest.raises(TypeError, match="argument"):
        _axpy(np.ones(3), 0)


_SCRIPT = """
import os, numpy as np, numba
from raycast_shade.common.inline import inline_jit

@inline_jit(forceinline=True, _nrt=False)
def helper(a, i):
    return a[i] * 3.0

@numba.njit(cache=True)
def kernel(a):
    s = 0.0
    for i in range(a.shape[0]):
        s += helper(a, i)
    return s

@numba.njit(cache=True)
def kernel2(a):
    return helper(a, np.int64(1)) - helper(a, np.int64(0))

a = np.arange(4.0)
print(kernel(a), helper(a, 2), len(helper.overloads))
if os.environ.get("SECOND"):
    from raycast_shade.common.inline import NO_ANNOTATION
    print(kernel2(a), sum(helper._cache_hits.values()), sum(helper._cache_misses.values()),
          [c.type_annotation for c in helper.overloads.values()] == [NO_ANNOTATION])
"""


def test_a_cached_kernel_needs_no_helper_build_and_a_new_kernel_reads_it(tmp_path):
    # The second process loads the kernel from the disk cache and builds no helper; its Python
    # call runs the twin (a wrapperless build entered from Python would crash the process). The
    # third compiles a new kernel, linking the helper's IR read from the disk (no machine code).
    (tmp_path / "mod.py").write_text(textwrap.dedent(_SCRIPT))
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "cache"),
               PYTHONPATH=os.pathsep.join([str(tmp_path), os.path.dirname(os.path.dirname(raycast_shade.__file__))]))
    outs = [subprocess.run([sys.executable, "-c", "import mod"], cwd=tmp_path, env=dict(env, **extra),
                           capture_output=True, text=True, timeout=300) for extra in ({}, {}, {"SECOND": "1"})]
    for out in outs:
        assert out.returncode == 0, out.stderr
    assert outs[0].stdout.split()[:2] == ["18.0", "6.0"]
    assert outs[1].stdout.split() == ["18.0", "6.0", "0"]  # the kernel came from the cache: no helper build
    # Read from the disk, not built; its entry keeps no annotated source.
    assert outs[2].stdout.split() == ["18.0", "6.0", "0", "3.0", "1", "0", "True"]
    names = [p.name for p in (tmp_path / "cache").rglob("mod.*")]
    assert any("helper" + TWIN_SUFFIX in n for n in names), names


# The modules whose helpers are built by inline_jit (the gradient modules keep njit: not on a
# frame's path).
CONVERTED = ("shading.bump", "shading.gouraud", "shading.gouraud_sides", "shading.illumination", "shading.mirror_rays",
             "shading.mirrors", "shading.normalmap", "shading.phong", "shading.phong_fast", "shading.pixelstore",
             "shading.records", "shading.reflectance", "shading.shadows", "shading.surface", "shading.terms_gouraud",
             "shading.terms_kernel", "shading.texture", "visibility.cast", "visibility.embree", "visibility.hits",
             "visibility.holes", "visibility.secondary", "visibility.tiles", "common.parallel")


@pytest.mark.parametrize("name", CONVERTED)
def test_the_inlined_helpers_are_built_without_wrappers(name):
    mod = importlib.import_module("raycast_shade." + name)
    helpers = [v for v in vars(mod).values()
               if isinstance(v, CPUDispatcher) and v.targetoptions.get("forceinline") and v.py_func.__module__ == mod.__name__]
    wrapped = [v.py_func.__name__ for v in helpers if not isinstance(v, InlineDispatcher)]
    assert helpers and not wrapped, f"{name}: forceinline helpers built with wrappers: {wrapped}"


def test_a_kernels_wrappers_are_left_to_the_module_passes(monkeypatch):
    """``install_wrapper_passes``: LLVM's function passes run on a kernel's own module, not on its
    CPython and C wrappers' (the module passes optimise them with the rest), and the kernel, entered
    through the wrapper, still unboxes its records of arrays and computes what it did."""
    from numba.core import codegen
    from raycast_shade.common import inline

    assert inline.WRAPPER_PASSES
    seen = []
    numbas = codegen.CPUCodeLibrary._numbas_optimize_functions

    def spy(self, ll_module):
        seen.append(ll_module.name)
        return numbas(self, ll_module)

    monkeypatch.setattr(codegen.CPUCodeLibrary, "_numbas_optimize_functions", spy)
    inline.install_wrapper_passes()  # around the spy
    try:
        @numba.njit(cache=False)
        def kernel(rec, k):
            a, b = rec
            return a[k] * b[k] + a.sum()

        a, b = np.arange(4.0), np.array([2.0, 3.0, 4.0, 5.0])
        assert kernel((a, b), 2) == 2.0 * 4.0 + 6.0
    finally:
        monkeypatch.undo()
        inline.install_wrapper_passes()
    assert "wrapper" not in seen and "cfunc_wrapper" not in seen
    assert any(name not in inline._WRAPPER_MODULES for name in seen)  # the kernel's own module: Numba's passes
