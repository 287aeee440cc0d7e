"""Run the benchmark suite: ``python -m benchmarks [--quick] [--only NAME ...]``.

Each registered benchmark is a module of this package with ``main(argv)``
(called with ``["--quick"]`` in quick mode) or ``run(quick: bool)``, and
``outputs(quick)``, the files it writes; every ``bench_*.py`` module and the
other measuring scripts of this folder are registered (``tests/project/
test_benchmark_outputs.py`` checks it); one that
is not there yet is skipped with a message, and one that fails is reported
without stopping the others. CSVs go to ``benchmarks/results/`` and charts to
``docs/images/``; ``docs/benchmarks.md`` is then regenerated from the CSVs of
the mode that ran. A quick run writes the same names into the git-ignored
``out/quick/results/``, ``out/quick/images/`` and
``out/quick/benchmarks.md`` (:mod:`benchmarks.outputs`), so it changes no
tracked file and never overwrites a full run's numbers.

Exit status: 0 when every benchmark that exists ran, 1 when one failed, 2 on
a missing optional dependency (``pip install 'raycast_shade[bench]'``).
"""

from __future__ import annotations

import argparse
import csv
import glob
import importlib
import math
import os
import sys
import time
import traceback

from benchmarks.outputs import ROOT, doc_path, images_dir, results_dir, results_file, write_csv

# name, module, title, CSV and chart name patterns (in results_dir(quick) and images_dir(quick))
REGISTRY = [
    dict(name="core", module="benchmarks.bench_core", title="Core: one frame, stage by stage, against the baselines",
         csv=["core.csv"], images=["core_benchmark.png"]),
    dict(name="raster", module="benchmarks.bench_raster", title="Ray casting against the reference rasterizer",
         csv=["raster*.csv"], images=["raster*.png"]),
    dict(name="accuracy", module="benchmarks.accuracy", title="Speed against accuracy",
         csv=["accuracy*.csv"], images=["speed_vs_accuracy.png", "convergence.png"],
         doc_flag="--no-docs"),  # it also rewrites a block of docs/accuracy.md
    dict(name="auto", module="benchmarks.bench_auto", title="Auto mode against single methods",
         csv=["auto.csv"], images=[]),
    dict(name="batch", module="benchmarks.bench_batch",
         title="Batch rendering: serial against the process pool and Dask workers",
         csv=["batch.csv", "batch_pool.csv"], images=["batch_scaling.png", "batch_pool.png"]),
    dict(name="surfaces", module="benchmarks.bench_surfaces",
         title="Surfaces: two shadowing lights and a mirror against the primary-only frame",
         csv=["surfaces.csv"], images=[]),
    dict(name="peers", module="benchmarks.bench_peers",
         title="Peers: Mesa's llvmpipe and Open3D on the same scenes (needs the peers extra)",
         csv=["peers.csv"], images=["peers.png"], page="performance.md"),
    dict(name="limits", module="benchmarks.bench_limits",
         title="Limits: raw Embree packets, bandwidth, memory, load and cold start",
         csv=["limits.csv"], images=[], page="performance.md"),
    dict(name="threads", module="benchmarks.bench_threads",
         title="Threads: the frame on 1 and 2 threads, quiet and with a busy core",
         csv=["threads.csv"], images=[], page="performance.md"),
    dict(name="views", module="benchmarks.bench_views", title="Vision data sets: buffer files and views",
         csv=["views.csv"], images=[], page="vision.md"),
    dict(name="paths", module="benchmarks.bench_paths",
         title="Paths: buffers, writers and view sets against the plain frame",
         csv=["paths.csv"], images=["paths.png"], page="performance.md"),
    dict(name="shadows", module="benchmarks.bench_shadows",
         title="Shadow rays: the shadowed frame against the plain one and the rays' bare Embree floor",
         csv=["shadows.csv"], images=[], page="performance.md"),
    dict(name="aa", module="benchmarks.bench_aa", title="Anti-aliasing: cost per sample and edge error",
         csv=["aa.csv"], images=[], page="antialiasing.md"),
    dict(name="grad", module="benchmarks.bench_grad",
         title="Gradients: rs.grad of a 640x480 Phong frame against the frame", csv=["grad.csv"], images=[],
         page="gradients.md"),
    dict(name="grad_peers", module="benchmarks.bench_grad_peers",
         title="Gradients beside Mitsuba 3's llvm_ad_rgb on a diffuse sphere", csv=["grad_peers.csv"], images=[],
         page="gradients.md"),
    dict(name="explore", module="benchmarks.bench_explore", title="The explorer's frame rate",
         csv=["explore.csv"], images=[], page="teaching.md"),
    dict(name="corpus", module="benchmarks.corpus_check",
         title="Real files: the colour under each pixel against trimesh's lookup (a self-made corpus; the public "
               "corpora are run by hand)", csv=["corpus_selftest.csv"], images=[], page="files.md"),
    dict(name="vertex_rays", module="benchmarks.vertex_rays",
         title="Rays through vertices: leaks and misses, Embree alone and watertight",
         csv=["vertex_rays.csv"], images=[], page="failure-cases.md"),
    dict(name="vision_checks", module="benchmarks.vision_checks",
         title="Vision checks: exporters, lens distortion and optical flow against OpenCV, pycolmap and closed forms",
         csv=["vision_checks.csv"], images=[], page="vision.md"),
    dict(name="diagnose", module="benchmarks.diagnose_confusion",
         title="Diagnose: the confusion matrix of the student-image classifier, and its time at 640x480",
         csv=["diagnose_*.csv"], images=["diagnose_confusion.png"], page="diagnose.md"),
    dict(name="diagnose_outside", module="benchmarks.diagnose_outside",
         title="Diagnose on an independent shader's images: slips outside the catalogue, post-processing, photographs",
         csv=["outside_slips.csv"], images=[], page="diagnose.md"),
]


def _is_missing_extra(exc: BaseException) -> bool:
    from raycast_shade.study.metrics import MissingExtraError

    return isinstance(exc, MissingExtraError)


def _call(mod, quick: bool, extra=()):
    """Run one benchmark module; returns whatever it returned."""
    if hasattr(mod, "main"):
        out = mod.main((["--quick"] if quick else []) + list(extra))
        if isinstance(out, int) and not isinstance(out, bool) and out != 0:
            if out == 2:  # the argparse / missing-dependency convention: the module said why
                raise ImportError("main() returned exit status 2 (a missing optional dependency; see above)")
            raise RuntimeError(f"main() returned exit status {out}")
        return out
    if hasattr(mod, "run"):
        return mod.run(quick=quick)
    raise RuntimeError("the module has neither main(argv) nor run(quick)")


def _write_rows(rows, path):
    keys = []
    for r in rows:
        keys += [k for k in r if k not in keys]
    write_csv(path, rows)


def _files(patterns, folder):
    out = []
    for pat in patterns:
        for p in sorted(glob.glob(os.path.join(folder, pat))):
            if p not in out:
                out.append(p)
    return out


def _csv_table(path, max_rows=30):
    with open(path, newline="") as fh:
        rows = list(csv.reader(fh))
    if not rows:
        return "_(empty)_"
    head, body = rows[0], rows[1:]

    def cell(v):
        try:
            f = float(v)
        except ValueError:
            return v
        if math.isfinite(f) and f != int(f):
            return f"{f:.4g}"
        return v

    lines = ["| " + " | ".join(head) + " |", "|" + "|".join("---" for _ in head) + "|"]
    lines += ["| " + " | ".join(cell(c) for c in r) + " |" for r in body[:max_rows]]
    if len(body) > max_rows:
        lines.append(f"\n_{len(body) - max_rows} more rows in the file._")
    return "\n".join(lines)


def write_doc(status, quick: bool, path=None):
    """Regenerate ``docs/benchmarks.md`` (``benchmarks_quick.md`` in quick mode) from the CSVs and charts on disk."""
    path = path or doc_path(quick)
    results, images = results_dir(quick), images_dir(quick)
    mode = "quick (`--quick`: small sizes, few repeats)" if quick else "full"
    parts = [
        "# Benchmarks",
        "",
        "Generated by `python -m benchmarks" + (" --quick" if quick else "") + "`; do not edit by hand. "
        f"Mode: {mode}. Machine: {os.cpu_count()} cores"
        f" (shared; times are medians of repeats after a warm-up, JIT compile time apart).",
        "",
        "Run the suite with `python -m benchmarks` (full sizes and repeats) or "
        "`python -m benchmarks --quick` (small sizes, few repeats); a single benchmark with "
        "`python -m benchmarks --only accuracy`. CSVs are in "
        f"`{os.path.relpath(results, ROOT)}/`" + (" (quick mode: not tracked by git)" if quick else "") + ".",
        "See [accuracy.md](accuracy.md) for the method behind the accuracy numbers.",
        "Peers (Mesa llvmpipe, Open3D) and the limits (raw Embree packets, bandwidth, memory, load, cold start): "
        "[performance.md](performance.md).",
        "",
        "Every benchmark is registered here; one runs alone with `python -m benchmarks --only NAME` "
        "or `python -m benchmarks.MODULE [--quick]`. The figures of the docs come from "
        "`python -m docs.figures` ([docs/figures](figures/)).",
    ]
    for entry in REGISTRY:
        name = entry["name"]
        parts += ["", f"## {entry['title']} (`{name}`)", ""]
        if "page" in entry:
            parts += [f"Discussed in [{entry['page']}]({entry['page']}).", ""]
        st = status.get(name)
        if st is None:
            # A partial run (--only) keeps the other benchmarks' files from earlier runs.
            parts.append("_Not run in this invocation: the results below are the files on disk from an "
                         "earlier run in this mode._")
            parts.append("")
        elif st != "ok":
            parts.append(f"_Status: {st}._")
            parts.append("")
        if name == "accuracy":
            try:
                from benchmarks import accuracy

                parts.append(accuracy.summary_markdown(results))
            except Exception as exc:  # noqa: BLE001 - the doc must still be written
                parts.append(f"_accuracy summary unavailable: {exc}_")
            csvs = []
        else:
            csvs = _files(entry["csv"], results)
        for p in csvs:
            parts += [f"`{os.path.relpath(p, ROOT)}`:", "", _csv_table(p), ""]
        for p in _files(entry["images"], images):
            rel = os.path.relpath(p, os.path.dirname(path))
            parts += [f"![{name}]({rel})", ""]
        if not csvs and name != "accuracy" and not _files(entry["images"], images):
            parts.append("_No results on disk for this mode._")
    os.makedirs(os.path.dirname(path), exist_ok=True)
    with open(path, "w") as fh:
        fh.write("\n".join(parts).rstrip() + "\n")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m benchmarks", description="Run raycast_shade's benchmark suite.")
    ap.add_argument("--quick", action="store_true", help="small sizes, few repeats")
    ap.add_argument("--only", nargs="+", metavar="NAME", choices=[e["name"] for e in REGISTRY],
                    help="run only these benchmarks")
    ap.add_argument("--docs-only", action="store_true",
                    help="run nothing: regenerate docs/benchmarks.md (benchmarks_quick.md) from the files on disk")
    ap.add_argument("--no-docs", action="store_true", help="do not regenerate docs/benchmarks.md or benchmarks_quick.md (nor the fitted orders in docs/accuracy.md)")
    args = ap.parse_args(argv)

    if args.docs_only:
        write_doc({}, args.quick)  # every section then says its files are from an earlier run
        print(f"wrote {os.path.relpath(doc_path(args.quick), ROOT)}", file=sys.stderr)
        return 0
    status = {}
    code = 0
    t_all = time.perf_counter()
    for entry in REGISTRY:
        name = entry["name"]
        if args.only and name not in args.only:
            continue
        print(f"== {name}: {entry['title']}", file=sys.stderr, flush=True)
        try:
            mod = importlib.import_module(entry["module"])
        except ModuleNotFoundError as exc:
            if exc.name == entry["module"]:
                msg = f"skipped: {entry['module']} is not in this checkout"
                print(f"   {msg}", file=sys.stderr)
                status[name] = msg
                continue
            msg = (f"skipped: it needs {exc.name!r}, which is not installed "
                   "(pip install 'raycast_shade[bench]')")
            print(f"   {msg}", file=sys.stderr)
            status[name] = msg
            code = max(code, 2)
            continue
        t0 = time.perf_counter()
        try:
            extra = [entry["doc_flag"]] if args.no_docs and "doc_flag" in entry else []
            out = _call(mod, args.quick, extra)
        except Exception as exc:  # noqa: BLE001 - one failing benchmark must not stop the suite
            if _is_missing_extra(exc) or isinstance(exc, ImportError):
                msg = f"skipped: {exc}"
                code = max(code, 2)
            else:
                traceback.print_exc()
                msg = f"failed: {type(exc).__name__}: {exc}"
                code = 1
            print(f"   {msg}", file=sys.stderr)
            status[name] = msg
            continue
        if (not hasattr(mod, "main") and isinstance(out, list) and out and all(isinstance(r, dict) for r in out)):
            _write_rows(out, results_file(f"{name}.csv", args.quick))
        status[name] = "ok"
        print(f"   done in {time.perf_counter() - t0:.1f} s", file=sys.stderr, flush=True)
    if not args.no_docs:
        write_doc(status, args.quick)
        print(f"wrote {os.path.relpath(doc_path(args.quick), ROOT)}", file=sys.stderr)
    print(f"benchmarks: {time.perf_counter() - t_all:.1f} s in all; "
          + ", ".join(f"{k}: {v}" for k, v in status.items()), file=sys.stderr)
    return code


if __name__ == "__main__":
    sys.exit(main())
