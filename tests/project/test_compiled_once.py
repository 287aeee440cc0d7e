"""No Python function is compiled by Numba twice.

Numba keys its disk cache on a function's name, first line, signature and bytecode, not
on the compile flags: ``njit(parallel=True)(f)`` and ``njit()(f)`` share one cache entry,
and every later process runs whichever build was compiled first
(``tests/visibility/test_kernel_cache.py`` shows it). A second variant needs a function of
its own name (``visibility/cast.py``'s ``_serial_twin``). This test reads the source with
``ast`` and counts, per module, the places each function is compiled: a ``jit`` decorator
on its ``def``, and every ``njit(...)(f)`` or ``njit(...)(f.py_func)`` call.
"""

from __future__ import annotations

import ast
import collections
import pathlib
import textwrap

import raycast_shade

ROOT = pathlib.Path(raycast_shade.__file__).parent.parent
FOLDERS = ("raycast_shade", "benchmarks", "docs")


def _is_jit(node) -> bool:
    """``njit``, ``jit``, ``numba.njit``, ... or a call of one (``njit(cache=True)``)."""
    if isinstance(node, ast.Call):
        node = node.func
    name = node.attr if isinstance(node, ast.Attribute) else getattr(node, "id", "")
    return name in {"jit", "njit", "generated_jit"}


def _target(node) -> str | None:
    """The function a compile call is given: ``f`` for ``f`` and ``f.py_func``."""
    if isinstance(node, ast.Attribute) and node.attr == "py_func":
        node = node.value
    if isinstance(node, (ast.Name, ast.Attribute)):
        return ast.unparse(node)
    return None


def compiled_twice(source: str) -> dict[str, int]:
    """``{function: compile sites}`` for the functions of ``source`` compiled more than once."""
    sites = collections.Counter()
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            sites[node.name] += sum(_is_jit(d) for d in node.decorator_list)
        elif isinstance(node, ast.Call) and isinstance(node.func, ast.Call) and _is_jit(node.func) and node.args:
            name = _target(node.args[0])
            if name is not None:
                sites[name] += 1
    return {name: n for name, n in sites.items() if n > 1}


def _modules():
    for folder in FOLDERS:
        yield from sorted((ROOT / folder).rglob("*.py"))


def test_no_function_is_compiled_twice():
    found = {}
    for path in _modules():
        twice = compiled_twice(path.read_text(encoding="utf-8"))
        found.update({f"{path.relative_to(ROOT)}: {name}": n for name, n in twice.items()})
    assert not found, ("one cache entry shared by two builds; give the second variant a function of its own "
                       f"(visibility/cast.py's _serial_twin): {found}")


def test_the_check_finds_every_form_of_a_pair():
    """Not vacuous: scan.py's old pairs, a decorated kernel compiled again through ``py_func``,
    and ``numba.jit``; a renamed twin and one compile per function pass."""
    old_scan = textwrap.dedent("""
        def _project(a):
            pass
        _project_par = njit(cache=True, parallel=True)(_project)
        _project_ser = njit(cache=True)(_project)
    """)
    assert compiled_twice(old_scan) == {"_project": 2}
    decorated = textwrap.dedent("""
        @numba.njit(cache=True, parallel=True)
        def kernel(a):
            pass
        kernel_serial = numba.jit(nopython=True, cache=True)(kernel.py_func)
    """)
    assert compiled_twice(decorated) == {"kernel": 2}
    fine = textwrap.dedent("""
        @njit(cache=True, parallel=True)
        def kernel(a):
            pass
        kernel_serial = _serial_twin(kernel, "kernel_serial")
        helper = njit(**HELPER)(helper_py)
    """)
    assert compiled_twice(fine) == {}


def test_the_walk_reads_the_kernels():
    """Not vacuous: the walk covers the modules that compile kernels both ways."""
    paths = {str(p.relative_to(ROOT)) for p in _modules()}
    assert {"raycast_shade/visibility/scan.py", "raycast_shade/visibility/cast.py",
            "raycast_shade/shading/illumination.py"} <= paths
