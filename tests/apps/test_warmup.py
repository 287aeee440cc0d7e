"""raycast-shade warmup / rs.warmup(): after it, a new process renders the lecture's kinds of frames
without compiling a kernel (each Numba compile fires a numba:compile event; a cache load does not)."""

from __future__ import annotations

import os
import pathlib
import subprocess
import sys

import pytest

import raycast_shade as rs
from raycast_shade.apps import warmup as wu

ROOT = pathlib.Path(__file__).resolve().parents[2]

# Another process, other scenes than warm-up's (sizes, meshes, lights, options), counting compiles.
AFTER = """
import warnings
import numpy as np
import raycast_shade as rs
from numba.core import event
warnings.simplefilter("ignore")
with event.install_recorder("numba:compile") as rec:
    torus = rs.shapes.torus(1.0, 0.3, 24, 12)
    spot = rs.SpotLight(position=(0.5, 3.0, 1.0), direction=(0.0, -1.0, -0.2), intensity=3.0, exponent=4,
                        inner_angle=25, outer_angle=40, shadows=True)
    sun = rs.DirectionalLight((-1.0, -2.0, -1.0), intensity=0.8)
    scene = rs.Scene([rs.Model(torus, rs.Material(kd=(0.2, 0.5, 0.8), ks=0.7, shininess=80)),
                      rs.Model(rs.shapes.plane(6.0, subdivisions=3, center=(0, -0.5, 0), normal="+y"),
                               rs.Material(kd=0.5, reflectivity=0.2))],
                     lights=[spot, sun], camera=rs.Camera(eye=(0.5, 2.0, 3.5), width=50, height=37), ambient=0.05)
    for m in ("flat", "gouraud", "phong"):
        for interp in ("perspective", "screen"):
            f = rs.render(scene, m, interpolation=interp, terms=True)
    f.overlay(wireframe=True)
    f.to_uint8()
    ys, xs = np.nonzero(f.mask)
    f.explain(int(xs[5]), int(ys[5]))
print("COMPILED", sum(1 for _, ev in rec.buffer if ev.is_start))
"""


def _env():
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(ROOT)] + [p for p in env.get("PYTHONPATH", "").split(os.pathsep) if p])
    return env


def test_after_warmup_a_new_process_compiles_nothing():
    first = subprocess.run([sys.executable, "-m", "raycast_shade", "warmup", "--no-progress"], capture_output=True,
                           text=True, env=_env(), timeout=1800)
    assert first.returncode == 0, first.stderr
    assert first.stdout.startswith("warm-up: ") and len(first.stdout.splitlines()) == 1 + len(wu.STEPS)
    again = subprocess.run([sys.executable, "-m", "raycast_shade", "warmup", "--no-progress"], capture_output=True,
                           text=True, env=_env(), timeout=600)
    assert again.returncode == 0, again.stderr
    assert "the cache was warm" in again.stdout
    assert all(line.endswith("compiled 0") for line in again.stdout.splitlines()[1:])
    after = subprocess.run([sys.executable, "-c", AFTER], capture_output=True, text=True, env=_env(), timeout=600)
    assert after.returncode == 0, after.stderr
    assert after.stdout.split()[-2:] == ["COMPILED", "0"], after.stdout


def test_report_counts_compiles_per_step_and_prints_a_table(monkeypatch, capsys):
    monkeypatch.setitem(sys.modules, "tqdm.auto", None)  # no tqdm: one plain line per step on stderr
    report = rs.warmup()
    assert [name for name, _, _ in report.steps] == [name for name, _ in wu.STEPS]
    assert all(seconds >= 0 and compiled >= 0 for _, seconds, compiled in report.steps)
    assert report.seconds >= sum(s for _, s, _ in report.steps)
    err = capsys.readouterr().err.splitlines()
    assert err[0] == f"warm-up 1/{len(wu.STEPS)}: {wu.STEPS[0][0]} ..." and len(err) == len(wu.STEPS)
    # In this process every kernel is now loaded: a second run compiles none.
    second = rs.warmup(progress=False)
    assert second.compiled == 0 and "the cache was warm" in str(second)
    assert str(second).count("compiled 0") == len(wu.STEPS)
    assert capsys.readouterr().err == ""


def test_warmup_refuses_a_progress_that_is_not_a_bool():
    with pytest.raises(TypeError, match="progress"):
        rs.warmup(progress="yes")


def test_cli_help_lists_warmup():
    from raycast_shade.apps.cli import build_parser

    assert "warmup" in build_parser().format_help()
