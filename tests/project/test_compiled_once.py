"""No Python function is compiled by Numba twice, and no kernel is a parfor.

Numba keys its disk cache on a function's name, first line, signature and bytecode, not
on the compile flags: ``njit(parallel=True)(f)`` and ``njit()(f)`` share one cache entry,
and every later process runs whichever build was compiled first. This test reads the
source with ``ast`` and counts, per module, the places each function is compiled: a
``jit`` decorator on its ``def``, and every ``njit(...)(f)`` or ``njit(...)(f.py_func)`` call.

A parallel kernel is a kernel in parts (``common/parallel.py``): one build serves the
threads and the serial call. ``parallel=True`` compiles a loop's body a second time as a
gufunc, and re-optimises everything it calls (the demo's first picture: 84 s of CPU with
the parfors, 61 s in parts, 2026-12-05), so the package has none.
"""

from __future__ import annotations

import ast
import collections
import os
import pathlib
import subprocess
import sys
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
                       f"(or run a kernel in parts whole: InParts.serial): {found}")


def parfors(source: str) -> list[str]:
    """The functions of ``source`` compiled with ``parallel=True`` or looping over ``prange``."""
    found = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            flags = [k for d in node.decorator_list if isinstance(d, ast.Call) and _is_jit(d) for k in d.keywords]
            par = any(k.arg == "parallel" and not (isinstance(k.value, ast.Constant) and not k.value.value)
                      for k in flags)
            loops = any(isinstance(n, ast.For) and isinstance(n.iter, ast.Call)
                        and ast.unparse(n.iter.func).split(".")[-1] == "prange" for n in ast.walk(node))
            if par or loops:
                found.append(node.name)
    return found


def test_no_kernel_is_a_parfor():
    found = {}
    for path in _modules():
        if path.parts[-2] != "__pycache__":
            names = parfors(path.read_text(encoding="utf-8"))
            if names:
                found[str(path.relative_to(ROOT))] = names
    assert not found, f"a parallel kernel is a kernel in parts (common/parallel.py), not a parfor: {found}"


def test_the_parfor_check_finds_both_forms():
    src = textwrap.dedent("""
        @njit(cache=True, parallel=True)
        def a(x):
            pass
        @numba.njit(nogil=True)
        def b(x):
            for i in numba.prange(3):
                pass
        @njit(nogil=True, parallel=False)
        def c(x, part):
            for i in range(*share(3, part)):
                pass
    """)
    assert parfors(src) == ["a", "b"]


def test_the_check_finds_every_form_of_a_pair():
    """Not vacuous: scan.py's old pairs, a decorated kernel compiled again through ``py_func``,
    and ``numba.jit``; a kernel in parts called whole and one compile per function pass."""
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
        @in_parts
        @njit(cache=True, nogil=True)
        def kernel(a, part):
            pass
        kernel_serial = kernel.serial
        helper = njit(**HELPER)(helper_py)
    """)
    assert compiled_twice(fine) == {}


def test_the_walk_reads_the_kernels():
    """Not vacuous: the walk covers the modules that compile kernels both ways."""
    paths = {str(p.relative_to(ROOT)) for p in _modules()}
    assert {"raycast_shade/visibility/scan.py", "raycast_shade/visibility/cast.py",
            "raycast_shade/shading/illumination.py"} <= paths


# A new process with an empty kernel cache: callers that pass helpers constants (tiles.tile_hits'
# lane offsets, shadows.store_point's and stored_point's field offsets, mirrors._prefetch_ahead's
# depth flag), compiled from scratch.
_CONSTANTS = """
import collections
import numpy as np
from numba import njit
from numba.core import event
from raycast_shade.shading import mirrors, shadows
from raycast_shade.shading.records import Hit
from raycast_shade.visibility import embree, tiles

@njit
def round_trip(points, hp):
    shadows.store_point(points, 0, hp, 2)
    return shadows.stored_point(points, 0)

@njit
def unpack(pk, pu, prim, geom, u, v, t):
    tiles.tile_hits(pk, pu, 0, 4, prim, geom, u, v, t)

@njit
def ahead(prim, geom, G, face_off):
    mirrors._prefetch_ahead(prim, geom, G, face_off, (0, 4), 64, 0, False)

with event.install_recorder("numba:compile") as rec:
    hp = Hit((1.0, 2.0, 3.0), (4.0, 5.0, 6.0), (7.0, 8.0, 9.0), -1.0, (10.0, 11.0, 12.0), (13.0, 14.0, 15.0))
    back = round_trip(np.zeros((1, 29)), hp)
    pk = np.arange(embree.RAYHIT_SLOTS * tiles.LANES, dtype=np.float32)
    flat = [np.zeros(16, np.int32), np.zeros(16, np.int32)] + [np.zeros(16, np.float32) for _ in range(3)]
    unpack(pk, pk.view(np.uint32), *flat)
    G = (np.zeros((3, 3)), np.zeros((3, 3)), np.zeros((1, 3), np.int32), np.zeros((1, 3)))
    ahead(np.zeros((4, 64), np.int32), np.zeros((4, 64), np.int32), G, np.zeros(1, np.int64))
names = collections.Counter(ev.data["dispatcher"].py_func.__qualname__ for _, ev in rec.buffer if ev.is_start)
print("ROUND", back == (hp.p, hp.v, hp.g, hp.sgn, hp.n, hp.o))
print("TWICE", sorted(n for n, c in names.items() if c > 1 and n != "impl"))
print("SEEN", all(n in names for n in ("_put3", "_get3", "_hits4", "_prefetch_tile")))
"""


def test_a_helper_given_constants_compiles_once(tmp_path):
    """Numba types a constant argument as ``Literal[int]`` and compiles a helper once per value
    (``_put3`` five times, ``_hits4`` three): the callers pass ``np.int64`` (``np.bool_``) values, and an
    empty cache compiles each helper once (the demo's first run: 177 compiles, was 200)."""
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path),
               PYTHONPATH=os.pathsep.join([str(ROOT)] + [p for p in os.environ.get("PYTHONPATH", "").split(os.pathsep)
                                                           if p]))
    run = subprocess.run([sys.executable, "-c", _CONSTANTS], capture_output=True, text=True, env=env, timeout=600)
    assert run.returncode == 0, run.stderr
    assert run.stdout.splitlines() == ["ROUND True", "TWICE []", "SEEN True"], run.stdout
