"""Numba's disk cache and kernels compiled twice, parallel and serial (issue 21's scan.py question).

Numba keys a cached kernel on its function's qualified name, first line, signature and
bytecode, not on ``parallel``: two dispatchers of one Python function share one cache
entry, and in every later process both run whichever build was compiled first (measured
on Numba 0.68 with scan.py's ``_project`` compiled both ways from one function: the serial
build compiled first made the parallel dispatcher run serially, and the other way round).
A serial twin therefore gets a name of its own (``cast._serial_twin``), as ``scan.py``'s
``_project_ser``, ``_setup_ser`` and ``_bin_fill_ser`` do, and
``tests/project/test_compiled_once.py`` finds any function compiled twice. Each test here
compiles the two variants in a fresh ``NUMBA_CACHE_DIR`` in a child process, then calls
each variant alone in a new process and reads whether it loaded a parallel build: a
parallel build launches Numba's thread pool when it runs
(``numba.np.ufunc.parallel._is_initialized``), a serial one does not.
"""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap

import pytest

_SCAN_CHILD = textwrap.dedent("""
    import sys
    import numpy as np
    from numba.np.ufunc import parallel
    from raycast_shade.visibility import scan

    assert not parallel._is_initialized
    for which in sys.argv[1:]:
        fn = {"ser": scan._project_ser, "par": scan._project_par}[which]
        n = 8
        verts = np.random.default_rng(0).normal(size=(n, 3))
        fn(verts, np.eye(4, 3), 0.1, False, 64.0, 48.0, 1.0, 1.0, np.zeros((n, 3)), np.zeros((n, 4)))
        hits = sum(fn.stats.cache_hits.values())
        print(which, "hit" if hits else "compiled", "threads" if parallel._is_initialized else "serial")
""")

_TWIN_MODULE = textwrap.dedent("""
    import numpy as np
    from numba import njit, prange

    from raycast_shade.visibility.cast import _serial_twin


    @njit(cache=True, parallel=True)
    def total(a):
        s = 0.0
        for i in prange(a.shape[0]):
            s += a[i]
        return s


    total_serial = _serial_twin(total, "total_serial")
""")

_TWIN_CHILD = textwrap.dedent("""
    import sys
    import numpy as np
    from numba.np.ufunc import parallel
    import twin_kernels

    assert not parallel._is_initialized
    for which in sys.argv[1:]:
        fn = {"ser": twin_kernels.total_serial, "par": twin_kernels.total}[which]
        assert fn(np.arange(64.0)) == 2016.0
        hits = sum(fn.stats.cache_hits.values())
        print(which, "hit" if hits else "compiled", "threads" if parallel._is_initialized else "serial")
""")


def _run(code, args, cache_dir, extra_path=()):
    env = dict(os.environ, NUMBA_CACHE_DIR=str(cache_dir))
    env["PYTHONPATH"] = os.pathsep.join([*map(str, extra_path), *sys.path])
    proc = subprocess.run([sys.executable, "-c", code, *args], env=env, capture_output=True, text=True,
                          timeout=900)
    assert proc.returncode == 0, proc.stderr[-3000:]
    return proc.stdout.split()


def _loaded_builds(code, first, cache_dir, extra_path=()):
    """Compile ``first`` then the other variant in one process (both saved to the cache), then
    run each variant alone in a fresh process: ``{variant: "threads" or "serial"}`` as loaded."""
    other = "par" if first == "ser" else "ser"
    compiled = _run(code, [first, other], cache_dir, extra_path)
    assert compiled[1] == "compiled"  # the first variant was not in the fresh cache
    loaded = {}
    for which in ("ser", "par"):
        which_, how, build = _run(code, [which], cache_dir, extra_path)
        assert which_ == which and how == "hit"  # every later process loads from the cache
        loaded[which] = build
    return loaded


@pytest.mark.parametrize("first", ["ser", "par"])
def test_a_renamed_serial_twin_loads_its_own_build(tmp_path, first):
    """``cast._serial_twin``'s remedy: under its own name the twin has its own cache entry,
    and each variant loads its own build whichever was compiled first."""
    (tmp_path / "twin_kernels.py").write_text(_TWIN_MODULE)
    loaded = _loaded_builds(_TWIN_CHILD, first, tmp_path / "cache", extra_path=[tmp_path])
    assert loaded == {"ser": "serial", "par": "threads"}


@pytest.fixture(scope="module")
def scan_builds(tmp_path_factory):
    """``{first: loaded builds}`` for scan.py's ``_project``, each order measured once."""
    done = {}

    def loaded(first):
        if first not in done:
            done[first] = _loaded_builds(_SCAN_CHILD, first, tmp_path_factory.mktemp(f"cache_{first}"))
        return done[first]

    return loaded


@pytest.mark.parametrize("first", ["ser", "par"])
def test_scan_variants_load_their_own_builds(scan_builds, first):
    """scan.py's serial and parallel ``_project`` each load their own build, whichever
    was compiled first."""
    assert scan_builds(first) == {"ser": "serial", "par": "threads"}
