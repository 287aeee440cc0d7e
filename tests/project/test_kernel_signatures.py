"""The Numba layer passes records, not long argument lists: no jitted function (or function
compiled by ``njit(...)(f)``, or a kernel built inside a variant factory) takes more than
MAX_PARAMETERS parameters, and the shading helpers that once took 20 to 28 take their records."""

from __future__ import annotations

import ast
import inspect
import pathlib

import raycast_shade
from raycast_shade.shading import gouraud, illumination, phong

PKG = pathlib.Path(raycast_shade.__file__).parent
MAX_PARAMETERS = 15


def _count(fn: ast.FunctionDef) -> int:
    a = fn.args
    return len(a.posonlyargs) + len(a.args) + len(a.kwonlyargs) + (a.vararg is not None) + (a.kwarg is not None)


def _jitted(tree):
    """Functions decorated with njit/jit, and those passed to ``njit(...)(name)`` in the module."""
    wrapped = set()
    for node in ast.walk(tree):
        if (isinstance(node, ast.Call) and isinstance(node.func, ast.Call) and node.args
                and isinstance(node.args[0], ast.Name) and "jit" in ast.unparse(node.func.func)):
            wrapped.add(node.args[0].id)
    for node in ast.walk(tree):
        if isinstance(node, ast.FunctionDef):
            decos = " ".join(ast.unparse(d) for d in node.decorator_list)
            if "jit" in decos or node.name in wrapped:
                yield node


def test_no_numba_function_takes_more_than_fifteen_parameters():
    long = []
    for path in sorted(PKG.rglob("*.py")):
        tree = ast.parse(path.read_text(encoding="utf-8"))
        long += [f"{path.relative_to(PKG)}:{fn.lineno} {fn.name}({_count(fn)})" for fn in _jitted(tree)
                 if _count(fn) > MAX_PARAMETERS]
    assert not long, "pass a record (a tuple or named tuple) instead: " + ", ".join(long)


def test_the_checker_sees_the_kernels():
    """Not vacuous: the walk finds the factories' kernels and the njit(...)(f) helpers."""
    names = set()
    for module in (phong, illumination, gouraud):
        names |= {fn.name for fn in _jitted(ast.parse(inspect.getsource(module)))}
    assert {"_shade_phong_kernel", "_shade_surface", "_illuminate_py", "_interp_gouraud_kernel"} <= names


def test_the_shading_helpers_take_records():
    params = lambda f: list(inspect.signature(getattr(f, "py_func", f)).parameters)  # noqa: E731
    assert params(illumination._illuminate_py) == ["hp", "coef", "mats", "mi", "L", "S", "spec_on", "att_on"]
    assert params(phong._surface) == ["G", "B", "cam", "at", "use_dir", "d"]
    assert len(params(phong._shade_surface)) == 12
