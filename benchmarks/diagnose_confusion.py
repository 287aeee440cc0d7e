"""The diagnosis as a classifier: its confusion matrix, and the time to diagnose a 640x480 image.

Run ``python -m benchmarks.diagnose_confusion [--quick]``. For three scenes (a
shiny sphere under an inverse-square light; a Blinn torus under a heuristic
light and a coloured directional one; a plane and a cube under a point light
without attenuation and a spot light), each of the three methods, and every
candidate of the catalogue (:mod:`raycast_shade.study.diagnose.catalogue`),
a student's image is made by the variant shader with that mistake and
diagnosed, under two conditions:

* ``noise``: 8-bit quantisation of the image plus Gaussian noise of 1 level;
* ``aa4``: the student anti-aliases with 4 rays per pixel (our sample
  pattern, each sample shaded by the variant, averaged in linear light),
  then the same quantisation and noise;
* ``jpeg90``: the ``noise`` image saved as a JPEG of quality 90.

A diagnosis is *right* when it gives a verdict ("matches" or "best
explained by") and the true candidate is in the diagnosed class (the
candidates indistinguishable from the best on that scene) -- for a correct
image, when it is diagnosed as matching --, *honest* when it says "cannot
tell" (or "not a render"), *wrong* otherwise; and *exact* when the
named best is the true candidate itself. A right diagnosis of a mistake
whose class holds the correct image is counted as *invisible*: on that
scene the slip does not change the image beyond the tolerance (the verdict
says "matches" and names it among the indistinguishable).

Writes ``benchmarks/results/diagnose_confusion.csv`` (the trials of each
scene, method, condition and true candidate: counts and the diagnoses),
``diagnose_summary.csv`` (per candidate), ``diagnose_classes.csv`` (the
equivalence classes met), ``diagnose_timing.csv`` and the figure
``docs/images/diagnose_confusion.png``; a quick run writes the same names
under the git-ignored ``quick/`` folders (:mod:`benchmarks.outputs`).
"""

from __future__ import annotations

import argparse
import collections
import csv
import os
import statistics
import time

import numpy as np

from benchmarks.outputs import image_file, results_file, write_csv

NAMES = ("diagnose_confusion.csv", "diagnose_summary.csv", "diagnose_classes.csv", "diagnose_timing.csv")


def outputs(quick: bool) -> list:
    """Every file :func:`main` writes in this mode."""
    return [results_file(n, quick) for n in NAMES] + [image_file(n, quick) for n in (
        "diagnose_confusion.png", "diagnose_gallery.png", "diagnose_example.png")]


def scenes(width: int, height: int) -> dict:
    """name -> Scene: the three scenes of the study (also those of tests/study/test_diagnose.py)."""
    import raycast_shade as rs

    sphere = rs.Scene([rs.Model(rs.shapes.icosphere(3), rs.Material(kd=(0.8, 0.3, 0.2), ks=0.5, shininess=40))],
                      lights=[rs.PointLight((2, 3, 4), intensity=20, attenuation="inverse_square")],
                      camera=rs.Camera(eye=(0, 0, 4), width=width, height=height), ambient=0.1)
    torus = rs.Scene([rs.Model(rs.shapes.torus(), rs.Material(kd=(0.2, 0.6, 0.3), ks=0.4, shininess=20,
                                                              specular="blinn"))],
                     lights=[rs.PointLight((2, 2, 3), intensity=6, attenuation="heuristic", k=1.0),
                             rs.DirectionalLight((-1, -1, -1), intensity=0.3, color=(0.2, 0.4, 1.0))],
                     camera=rs.Camera(eye=(0, 2.5, 3), width=width, height=height), ambient=0.05)
    plane = rs.Model(rs.shapes.plane(size=3.0, subdivisions=8, normal="+y"),
                     rs.Material(kd=(0.5, 0.5, 0.7), ks=0.3, shininess=15))
    cube = rs.Model(rs.shapes.cube(0.8, center=(0, 0.4, 0)), rs.Material(kd=(0.9, 0.7, 0.2), ks=0.6, shininess=60))
    floor = rs.Scene([plane, cube],
                     lights=[rs.PointLight((1.5, 2, 1.5), intensity=0.8),
                             rs.SpotLight((-1, 2.5, 1), direction=(0.4, -1, -0.3), intensity=9,
                                          attenuation="inverse_square", exponent=4, inner_angle=25, outer_angle=40)],
                     camera=rs.Camera(eye=(0.5, 2.5, 3.5), target=(0, 0, 0), width=width, height=height), ambient=0.08)
    return {"sphere": sphere, "torus": torus, "plane+cube": floor}


def antialiased(scene, method, mistake, samples: int) -> np.ndarray:
    """The variant's image with ``samples`` rays per pixel, averaged in linear light, encoded: levels 0..255."""
    import raycast_shade as rs
    from raycast_shade.common.samples import sample_offsets
    from raycast_shade.study.diagnose import encode, shade_variant

    acc = 0.0
    shift = -0.5 if mistake.half_pixel else 0.0
    for dx, dy in sample_offsets(samples):
        hits = rs.cast_camera(scene.geometry, scene.camera, offset=(dx + shift, dy + shift))
        acc = acc + shade_variant(scene, scene.camera, hits, method, mistake)
    return encode(acc / samples, mistake) * 255.0


CONDITIONS = ("noise", "aa4", "jpeg90")


def _jpeg(img):
    """``img`` written as a JPEG of quality 90 and read back (through Pillow, in memory)."""
    import imageio.v3 as iio

    return iio.imread(iio.imwrite("<bytes>", img, extension=".jpg", quality=90), extension=".jpg")


def _quantise(img, rng, sigma):
    return np.clip(np.rint(img + rng.normal(0.0, sigma, img.shape)), 0, 255).astype(np.uint8)


def classify(sizes, trials: int, seed: int = 25):
    """Every trial as a dict row, and the classes met."""
    from raycast_shade.apps.diagnose import Diagnoser

    rng = np.random.default_rng(seed)
    rows, classes = [], set()
    for width, height in sizes:
        for sname, scene in scenes(width, height).items():
            for method in ("flat", "gouraud", "phong"):
                diag = Diagnoser(scene, method)
                for cand in diag.candidates:
                    for condition in CONDITIONS:
                        clean = antialiased(scene, method, cand.mistake, 4) if condition == "aa4" else \
                            diag.images[cand.name]
                        for trial in range(trials):
                            image = _quantise(clean, rng, 1.0)
                            d = diag(_jpeg(image) if condition == "jpeg90" else image)
                            # right: a verdict whose class holds the truth; honest: "cannot tell" / "not a render"
                            right = d.matches if cand.correct else (d.explained and cand.name in d.group)
                            honest = not d.explained
                            classes.add((sname, method, width, d.group)) if len(d.group) > 1 else None
                            rows.append(dict(width=width, height=height, condition=condition, scene=sname,
                                             method=method, truth=cand.name, trial=trial, best=d.best.name,
                                             group="|".join(d.group), right=int(right),
                                             honest=int(honest), wrong=int(not right and not honest),
                                             exact=int(d.best.name == cand.name), matches=int(d.matches),
                                             invisible=int(d.matches and not cand.correct and right),
                                             rms_best=round(d.scores[d.best.name], 4),
                                             rms_truth=round(d.scores[cand.name], 4)))
    return rows, sorted(classes)


def aggregate(rows) -> list:
    """The trials of each (size, condition, scene, method, true candidate) in one row: counts, the
    diagnoses as ``name:count`` pairs, the mean class size and RMS values."""
    cells = collections.defaultdict(list)
    for r in rows:
        cells[(r["width"], r["height"], r["condition"], r["scene"], r["method"], r["truth"])].append(r)
    out = []
    for (w, h, cond, scene, method, truth), rs_ in cells.items():
        named = collections.Counter(r["best"] for r in rs_)
        out.append(dict(width=w, height=h, condition=cond, scene=scene, method=method, truth=truth, trials=len(rs_),
                        right=sum(r["right"] for r in rs_), honest=sum(r["honest"] for r in rs_),
                        wrong=sum(r["wrong"] for r in rs_), exact=sum(r["exact"] for r in rs_),
                        matches=sum(r["matches"] for r in rs_), invisible=sum(r["invisible"] for r in rs_),
                        diagnosed=";".join(f"{k}:{v}" for k, v in named.most_common()),
                        class_size=round(float(np.mean([len(r["group"].split("|")) for r in rs_])), 3),
                        rms_best=round(float(np.mean([r["rms_best"] for r in rs_])), 4),
                        rms_truth=round(float(np.mean([r["rms_truth"] for r in rs_])), 4)))
    return out


def summary(cells) -> list:
    """Per true candidate: images, right and exact rates, invisible share, the commonest other diagnosis."""
    by = collections.defaultdict(list)
    for c in cells:
        by[c["truth"]].append(c)
    out = []
    for truth, cs in by.items():
        n = sum(c["trials"] for c in cs)
        named = collections.Counter()
        for c in cs:
            for pair in c["diagnosed"].split(";"):
                name, k = pair.rsplit(":", 1)
                named[name] += int(k)
        others = [(k, v) for k, v in named.most_common() if k != truth]
        out.append(dict(truth=truth, images=n, right=round(sum(c["right"] for c in cs) / n, 4),
                        exact=round(sum(c["exact"] for c in cs) / n, 4),
                        invisible=round(sum(c["invisible"] for c in cs) / n, 4),
                        commonest_other=others[0][0] if others else ""))
    return out


def timing(repeats: int, size=(640, 480)) -> list:
    """Seconds to diagnose a ``size`` image of the sphere scene (Phong), after a warm-up at 96x72."""
    import raycast_shade as rs

    small = scenes(96, 72)["sphere"]
    rs.diagnose(rs.to_uint8(rs.render(small, "phong").image), small, "phong")  # kernels loaded
    scene = scenes(*size)["sphere"]
    image = rs.to_uint8(rs.render(scene, "gouraud").image)
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        d = rs.diagnose(image, scene, "phong")
        times.append(time.perf_counter() - t0)
    assert d.best.name == "gouraud-shading", d.verdict
    return [dict(width=size[0], height=size[1], candidates=len(d.candidates), repeats=repeats,
                 median_s=round(statistics.median(times), 3), min_s=round(min(times), 3),
                 cpus=os.cpu_count(), note="shared machine, loaded")]


def figure(rows, path):
    """Left: true candidate against the diagnosis as named (the class's simplest member); right: the
    rates per candidate, right (the true candidate in the class) and exact (the class named by it)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = list(dict.fromkeys(c["truth"] for c in rows))
    index = {n: i for i, n in enumerate(names)}
    m = np.zeros((len(names), len(names) + 1))
    for c in rows:
        for pair in c["diagnosed"].split(";"):
            name, k = pair.rsplit(":", 1)
            m[index[c["truth"]], index.get(name, len(names))] += int(k)
    m /= m.sum(axis=1, keepdims=True)
    fig, (ax, bx) = plt.subplots(1, 2, figsize=(15, 9.5), dpi=80, gridspec_kw=dict(width_ratios=[2.3, 1]))
    ax.imshow(m, cmap="viridis", vmin=0, vmax=1)
    ax.set_xticks(range(len(names) + 1), names + ["(other)"], rotation=90, fontsize=7)
    ax.set_yticks(range(len(names)), names, fontsize=7)
    ax.set_xlabel("diagnosis as named (the simplest member of the class)")
    ax.set_ylabel("true candidate")
    for i in range(len(names)):
        for j in range(len(names) + 1):
            if m[i, j] > 0 and (i != j or m[i, j] < 1):
                ax.text(j, i, f"{100 * m[i, j]:.0f}", ha="center", va="center", fontsize=5.5,
                        color="black" if m[i, j] > 0.5 else "white")
    def rate(key, n):
        cs = [c for c in rows if c["truth"] == n]
        return sum(c[key] for c in cs) / sum(c["trials"] for c in cs)

    right = np.array([rate("right", n) for n in names])
    exact = np.array([rate("exact", n) for n in names])
    y = np.arange(len(names))
    bx.barh(y - 0.2, 100 * right, height=0.4, label="right (in the class)")
    bx.barh(y + 0.2, 100 * exact, height=0.4, label="exact (named)")
    bx.set_yticks(y, names, fontsize=7)
    bx.invert_yaxis()
    bx.set_xlim(0, 100)
    bx.set_xlabel("% of the candidate's images")
    bx.legend(loc="lower left", fontsize=8)
    images = sum(c["trials"] for c in rows)
    total = sum(c["right"] for c in rows) / images
    fig.suptitle(f"diagnose as a classifier: {images} images, {100 * total:.2f}% right")
    fig.tight_layout()
    os.makedirs(os.path.dirname(path), exist_ok=True)
    fig.savefig(path)
    plt.close(fig)


def doc_table(cells) -> str:
    """The results table of docs/diagnose.md, from the aggregated trials."""
    out = ["| size | condition | images | right | cannot tell | wrong | exact | invisible | mean class size | "
           "correct images matched |", "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
    for size in dict.fromkeys((c["width"], c["height"]) for c in cells):
        for cond in CONDITIONS:
            sub = [c for c in cells if (c["width"], c["height"]) == size and c["condition"] == cond]
            n = sum(c["trials"] for c in sub)
            cor = [c for c in sub if c["truth"] == "correct"]
            size_mean = sum(c["class_size"] * c["trials"] for c in sub) / n
            out.append(f"| {size[0]}x{size[1]} | {cond} | {n} | {100 * sum(c['right'] for c in sub) / n:.2f}% "
                       f"| {sum(c['honest'] for c in sub)} | {sum(c['wrong'] for c in sub)} "
                       f"| {100 * sum(c['exact'] for c in sub) / n:.2f}% | {sum(c['invisible'] for c in sub)} "
                       f"| {size_mean:.2f} | {sum(c['matches'] for c in cor)}/{sum(c['trials'] for c in cor)} |")
    return "\n".join(out)


def _read(path):
    with open(path, newline="") as fh:
        rows = list(csv.DictReader(fh))
    for r in rows:
        for k in ("trials", "right", "honest", "wrong", "exact", "matches", "invisible"):
            r[k] = int(r[k])
        r["class_size"] = float(r["class_size"])
    return rows


def gallery(path, width=128, height=96):
    """Every candidate's image of the sphere scene (Phong shading asked for), labelled, in one figure."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from raycast_shade.apps.diagnose import Diagnoser

    diag = Diagnoser(scenes(width, height)["sphere"], "phong")
    cands = diag.candidates
    cols = 8
    rows = (len(cands) + cols - 1) // cols
    fig, axes = plt.subplots(rows, cols, figsize=(cols * 1.6, rows * 1.45), dpi=100)
    for ax in axes.ravel():
        ax.axis("off")
    for ax, c in zip(axes.ravel(), cands):
        ax.imshow(np.clip(np.rint(diag.images[c.name]), 0, 255).astype(np.uint8))
        ax.set_title(c.name.replace("+", "+\n"), fontsize=6.5)
    fig.tight_layout(pad=0.3)
    fig.savefig(path)
    plt.close(fig)


def example(path, width=160, height=120):
    """A student's image (the torus without the sRGB encoding and without ambient), what we make of it."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    import raycast_shade as rs
    from raycast_shade.apps.diagnose import Diagnoser

    scene = scenes(width, height)["torus"]
    diag = Diagnoser(scene, "gouraud")
    lin = rs.render(scene.replace(ambient=0.0), "gouraud").image
    student = rs.to_uint8(lin, gamma=1.0)  # a student's renderer: no ambient, linear values written
    d = diag(student)
    correct = np.clip(np.rint(diag.images["correct"]), 0, 255).astype(np.uint8)
    panels = [(student, "student's image"), (correct, "ours (correct Gouraud)"),
              (np.abs(student.astype(float) - correct).mean(axis=2), "|student - ours| (levels)"),
              (d.map, f"|student - '{d.best.name}'|")]
    fig, axes = plt.subplots(1, 4, figsize=(12, 2.9), dpi=100)
    for ax, (img, title) in zip(axes, panels):
        if img.ndim == 2:
            cmap = matplotlib.colormaps["magma"].copy()
            cmap.set_bad("0.55")  # grey: silhouette and background pixels, not scored
            im = ax.imshow(img, cmap=cmap, vmin=0, vmax=max(8.0, float(np.nanmax(img))))
            fig.colorbar(im, ax=ax, fraction=0.035)
        else:
            ax.imshow(img)
        ax.set_title(title, fontsize=9)
        ax.axis("off")
    x, y = d.pixel
    for ax in axes:
        ax.plot([x], [y], marker="+", color="cyan", markersize=10)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
    return d


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="python -m benchmarks.diagnose_confusion", description=__doc__.split("\n")[0])
    p.add_argument("--quick", action="store_true", help="one size, one trial, no 640x480 timing repeats")
    p.add_argument("--figures", action="store_true", help="only the gallery and the example figures")
    p.add_argument("--from-csv", action="store_true",
                   help="redraw the confusion figure and print the docs table from the trials already written")
    args = p.parse_args(argv)
    quick = args.quick
    if args.from_csv:
        rows = _read(results_file(NAMES[0], quick))
        figure(rows, image_file("diagnose_confusion.png", quick))
        print(doc_table(rows))
        return 0
    gallery(image_file("diagnose_gallery.png", quick))
    print(example(image_file("diagnose_example.png", quick)))
    if args.figures:
        return 0
    sizes = [(96, 72)] if quick else [(96, 72), (192, 144)]
    rows, classes = classify(sizes, 1 if quick else 3)
    cells = aggregate(rows)
    write_csv(results_file(NAMES[0], quick), cells)
    summ = summary(cells)
    write_csv(results_file(NAMES[1], quick), summ)
    write_csv(results_file(NAMES[2], quick), [dict(scene=s, method=m, width=w, group="|".join(g))
                                              for s, m, w, g in classes] or [dict(scene="", method="", width="",
                                                                                    group="")])
    write_csv(results_file(NAMES[3], quick), timing(1 if quick else 3))
    figure(cells, image_file("diagnose_confusion.png", quick))
    print(doc_table(cells))
    for s in sorted(summ, key=lambda s: (s["right"], s["exact"]))[:8]:
        print(f"  {s['truth']:<40s} right {s['right']:.3f} exact {s['exact']:.3f} invisible {s['invisible']:.3f} "
              f"{s['commonest_other']}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
