"""Pictures and figures of the failure catalogue (``docs/failure-cases.md``).

Run ``python -m docs.figures.failure_cases [--only 1 4 ...] [--quick]``. Each case of
the catalogue renders a small scene that provokes the failure, measures it,
and draws the naive or plain result next to what the project does (or flat,
Gouraud and Phong side by side) into ``docs/images/failure_NN_name.png``. The
measured figures are printed and written to
``benchmarks/results/failure_cases.csv`` (case, quantity, value), the numbers
quoted in the catalogue. The scenes come from :mod:`raycast_shade.study.failure_scenes`,
which the tests (``tests/*/test_failure_cases.py``) assert the same figures on.
"""

from __future__ import annotations

import argparse
import csv
import os
import sys

import numpy as np

from benchmarks.outputs import images_dir, results_dir  # noqa: E402

RESULTS = results_dir(False)
IMAGES = images_dir(False)

import raycast_shade as rs  # noqa: E402
from raycast_shade.study import failure_scenes as fs  # noqa: E402
from raycast_shade.study.analytic import Plane, Sphere, exact_for_scene  # noqa: E402
from raycast_shade.study.metrics import angular_step, compare, convergence_order, normal_angles, rmse  # noqa: E402
from raycast_shade.study.reference import hit_points, illuminate_reference  # noqa: E402

ROWS: list[tuple[str, str, float]] = []


def record(case, name, value):
    ROWS.append((case, name, float(value)))
    print(f"  {case:>2} {name:<52} {float(value):.4g}")


# -- drawing -------------------------------------------------------------------------------------------

def _plt():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def figure(path, items, suptitle, width=2.3, height=2.1):
    """One row of panels: ``("img", image, title[, exposure])`` or ``("plot", fn(ax), title)``."""
    plt = _plt()
    fig, axes = plt.subplots(1, len(items), figsize=(width * len(items), height), squeeze=False)
    for ax, item in zip(axes[0], items):
        kind, content, title = item[:3]
        if kind == "img":
            exposure = item[3] if len(item) > 3 else 1.0
            ax.imshow(rs.to_uint8(content, exposure=exposure), interpolation="nearest")
            ax.set_xticks([])
            ax.set_yticks([])
        else:
            content(ax)
            ax.tick_params(labelsize=6)
            ax.grid(True, alpha=0.3)
        ax.set_title(title, fontsize=7.5)
    fig.suptitle(suptitle, fontsize=8.5)
    fig.tight_layout()
    os.makedirs(IMAGES, exist_ok=True)
    fig.savefig(os.path.join(IMAGES, path), dpi=100)
    plt.close(fig)
    print(f"  -> {os.path.join(IMAGES, path)}")


def _all(scene):
    return {m: rs.render(scene, m) for m in rs.SHADINGS}


def _shade_with(scene, frame, normals):
    """The reflectance equation at every hit pixel with the given normals (NumPy reference)."""
    geo = scene.geometry
    _, _, v, p = fs.raw_normals(scene, frame)
    from raycast_shade.study.reference import _lights, _materials

    out = np.zeros(frame.image.shape)
    out[frame.mask] = illuminate_reference(p, normals, v, geo.face_model[geo.face_offsets[frame.hits.geom[frame.mask]]
                                                                        + frame.hits.prim[frame.mask]],
                                           _materials(scene), _lights(scene, geo.origin), np.asarray(scene.ambient),
                                           1e-6 * geo.scale)
    return out


def _normal_rgb(n):
    return np.where(np.any(n != 0, axis=-1, keepdims=True), 0.5 * (n + 1.0), 0.0)


# -- 1 -------------------------------------------------------------------------------------------------

def case_1():
    scene = fs.highlight_plane_scene(kd=0.15)  # a little diffuse light to show the plane
    exact = exact_for_scene(scene, [Plane(size=4.0)])
    f = _all(scene)
    spec = fs.highlight_plane_scene()
    f_spec = _all(spec)
    ex_s = exact_for_scene(spec, [Plane(size=4.0)])
    record(1, "highlight peak, exact image", ex_s.image.max())
    for m in rs.SHADINGS:
        record(1, f"highlight peak, {m}", f_spec[m].image.max())
    record(1, "phong max error vs exact (specular only)", np.abs(f_spec["phong"].image - ex_s.image).max())
    figure("failure_01_highlight.png",
           [("img", exact.image, "exact plane"), ("img", f["flat"].image, "flat"),
            ("img", f["gouraud"].image, "Gouraud: peak lost"), ("img", f["phong"].image, "Phong")],
           "1. A highlight inside one of two large triangles (t = 64)")

    # Mach bands on a tube.
    w = 128
    tscene = fs.tube_scene(6, width=w, height=48)
    ft = _all(tscene)
    x = (np.arange(w) + 0.5) / w * 2.0 - 1.0
    s = -tscene.lights[0].direction
    ex = np.maximum(0.0, x * s[0] + np.sqrt(1.0 - x**2) * s[2])
    inner = np.abs(x) < 0.6
    d2e = np.abs(np.diff(ex[inner], 2)).max()
    rows = {m: ft[m].image[24, :, 0].astype(np.float64) for m in rs.SHADINGS}
    for m in rs.SHADINGS:
        record(1, f"mach: max |d2 I| / exact's, 6 segments, {m}", np.abs(np.diff(rows[m][inner], 2)).max() / d2e)
        record(1, f"mach: median |d2 I| / exact's, {m}", np.median(np.abs(np.diff(rows[m][inner], 2))) / d2e)

    def slope(ax):
        for m, c in (("gouraud", "C1"), ("phong", "C2")):
            ax.plot(x[1:], np.diff(rows[m]) / (x[1] - x[0]), color=c, lw=1, label=m)
        ax.plot(x[1:], np.diff(ex) / (x[1] - x[0]), "k--", lw=0.8, label="exact")
        for xv in np.sin(np.linspace(-0.45 * np.pi, 0.45 * np.pi, 7)):
            ax.axvline(xv, color="gray", lw=0.5, ls=":")
        ax.set_xlim(-0.8, 0.8)
        ax.set_ylim(-3, 2)
        ax.legend(fontsize=6)
        ax.set_xlabel("x (dotted: vertex columns)", fontsize=6)

    figure("failure_01_mach.png",
           [("img", ft["flat"].image, "flat", 0.8), ("img", ft["gouraud"].image, "Gouraud", 0.8),
            ("img", ft["phong"].image, "Phong", 0.8), ("plot", slope, "slope dI/dx along a row")],
           "1. Mach bands: a 6-segment tube; Gouraud's slope jumps at every vertex column", width=2.6)


# -- 2 -------------------------------------------------------------------------------------------------

def case_2():
    steps, err = [], {m: [] for m in rs.SHADINGS}
    imgs = []
    exact = None
    for level in (1, 2, 3, 4):
        scene = fs.facet_sphere_scene(level)
        if exact is None:
            exact = exact_for_scene(scene, [Sphere()])
        steps.append(angular_step(scene.models[0].mesh))
        for m in rs.SHADINGS:
            fr = rs.render(scene, m)
            err[m].append(compare(exact, fr, use_ssim=False).rmse_interior)
            if m == "flat" and level in (1, 3):
                imgs.append(("img", fr.image, f"flat, level {level}"))
    for m in rs.SHADINGS:
        p, se = convergence_order(steps, err[m])
        record(2, f"convergence order (levels 1-4), {m}", p)
        for lv, e in zip((1, 2, 3, 4), err[m]):
            record(2, f"interior RMSE level {lv}, {m}", e)

    def conv(ax):
        for m, c in (("flat", "C0"), ("gouraud", "C1"), ("phong", "C2")):
            p, _ = convergence_order(steps, err[m])
            ax.loglog(steps, err[m], "o-", ms=3, color=c, label=f"{m}: {p:.2f}")
        from matplotlib.ticker import NullFormatter

        ax.xaxis.set_minor_formatter(NullFormatter())
        ax.set_xlabel("angular step (rad)", fontsize=6)
        ax.set_ylabel("interior RMSE", fontsize=6)
        ax.legend(fontsize=6, title="order", title_fontsize=6, loc="lower right")

    figure("failure_02_facets.png", imgs + [("img", exact.image, "exact sphere"), ("plot", conv, "error vs step")],
           "2. Flat shading's facets: the error falls only linearly with the angular step")


# -- 3 -------------------------------------------------------------------------------------------------

def case_3():
    scene = fs.checker_normals_scene()
    f = _all(scene)
    raw, g, v, p = fs.raw_normals(scene, f["phong"])
    naive = np.zeros(f["phong"].image.shape)
    ok = np.linalg.norm(raw, axis=1) > 0
    rawn = np.where(ok[:, None], raw, g)
    naive = _shade_with(scene, f["phong"], rawn)  # no orientation rule at all
    record(3, "checkerboard: phong - flat, max", np.abs(f["phong"].image - f["flat"].image).max())
    record(3, "checkerboard: gouraud - flat, max", np.abs(f["gouraud"].image - f["flat"].image).max())
    record(3, "checkerboard: unoriented phong - flat, max", np.abs(naive - f["flat"].image).max())
    fz = _all(fs.zero_normals_scene())
    record(3, "zero normals: phong - flat, max", np.abs(fz["phong"].image - fz["flat"].image).max())
    figure("failure_03_cancel.png",
           [("img", naive, "+-z normals, no rule", 0.6), ("img", f["gouraud"].image, "Gouraud = flat", 0.6),
            ("img", f["phong"].image, "Phong = flat", 0.6), ("img", fz["phong"].image, "zero normals: Phong = flat", 0.8)],
           "3. Vertex normals that cancel: the face normal takes over")


# -- 4 -------------------------------------------------------------------------------------------------

def case_4():
    scene = fs.silhouette_scene(0)
    exact = exact_for_scene(scene, [Sphere()])
    fr = rs.render(scene, "phong")
    raw, g, v, p = fs.raw_normals(scene, fr)
    away = fs.dot(raw, v) < 0
    naive = _shade_with(scene, fr, np.where(away[:, None], -raw, raw))
    both = exact.mask & fr.mask
    record(4, "icosphere(0): pixels with n.v < 0", away.sum())
    record(4, "icosphere(0): hit pixels", len(raw))
    record(4, "icosphere(0): min n.g", fs.dot(fr.normal[fr.mask].astype(float), g).min())
    record(4, "RMSE vs exact, ours (n kept)", rmse(exact.image, fr.image, both))
    record(4, "RMSE vs exact, faceforward on n.v", rmse(exact.image, naive, both))
    mark = fr.image.copy()
    sel = np.zeros(fr.mask.shape, bool)
    sel[fr.mask] = away
    mark[sel] = (1.0, 0.0, 0.0)
    # A normal field tipping past the tangent plane.
    tscene = fs.tipping_field_scene()
    tf = rs.render(tscene, "phong")
    traw, tg, _, _ = fs.raw_normals(tscene, tf)
    neg = traw.copy()
    neg[fs.dot(traw, tg) < 0] *= -1
    nbuf = np.zeros(tf.normal.shape)
    nbuf[tf.mask] = neg
    m = tf.mask
    n = tf.normal.astype(np.float64)
    record(4, "tipping field: max neighbour angle, reflection (deg)",
           normal_angles(n[:, 1:], n[:, :-1], m[:, 1:] & m[:, :-1]).max())
    record(4, "tipping field: max neighbour angle, negation (deg)",
           normal_angles(nbuf[:, 1:], nbuf[:, :-1], m[:, 1:] & m[:, :-1]).max())
    figure("failure_04_silhouette.png",
           [("img", exact.image, "exact sphere"), ("img", naive, "faceforward(n, v)"),
            ("img", fr.image, "ours: n kept"), ("img", mark, "red: n.v < 0 (allowed)"),
            ("img", _normal_rgb(nbuf), "tipping field: negated"), ("img", _normal_rgb(n), "reflected (ours)")],
           "4. Shading normals facing away from the eye: icosahedron (left), a normal field tipping past 90 degrees (right)",
           width=2.0)


# -- 5 -------------------------------------------------------------------------------------------------

def case_5():
    items = []
    flat = None
    for crease in (30.0, 89.0, 90.0, 91.0, None):
        scene = fs.cube_scene(crease)
        if flat is None:
            flat = rs.render(scene, "flat")
        fr = rs.render(scene, "phong")
        both = flat.mask & fr.mask
        record(5, f"cube crease {crease}: phong RMSE vs flat", rmse(flat.image, fr.image, both))
        record(5, f"cube crease {crease}: mean normal error (deg)", normal_angles(flat.normal, fr.normal, both).mean())
        if crease in (30.0, 91.0, None):
            items.append(("img", fr.image, f"crease {crease}" if crease else "no crease"))
    for crease in (15.0, 60.0, 120.0):  # with a highlight and ambient light to show the shape
        scene = fs.cylinder_scene(crease, rs.Material(kd=0.7, ks=0.3, shininess=20), ambient=0.05)
        items.append(("img", rs.render(scene, "phong").image, f"cylinder, crease {crease:g}"))
    figure("failure_05_crease.png", items, "5. Averaged normals across hard edges: the crease angle decides", width=2.0)


# -- 6 -------------------------------------------------------------------------------------------------

def _plane_points(camera, z0=0.0):
    from raycast_shade.study.twins import generate_rays_numpy

    o, d = generate_rays_numpy(camera)
    t = (z0 - o[:, 2]) / d[:, 2]
    return (o + t[:, None] * d).reshape(camera.height, camera.width, 3)


def case_6_degenerate():
    import trimesh

    plane = rs.shapes.plane(size=2.0, subdivisions=8)
    grid = _all(fs.lamp_scene(rs.Mesh(plane.vertices, plane.faces)))
    exact_p = _plane_points(fs.LAMP_CAMERA)
    for n in (200, 2000, 20000):
        scene = fs.lamp_scene(fs.sliver_fan(n))
        fan = _all(scene)
        pb = hit_points(scene, fan["phong"].hits)
        err = np.linalg.norm(pb - exact_p, axis=-1)[fan["phong"].mask]
        record(6, f"{n} slivers: hit point error from barycentrics, max", err.max())
        for m in rs.SHADINGS:
            record(6, f"{n} slivers: {m} - grid, max", np.abs(fan[m].image - grid[m].image).max())
        if n == 200:
            fan200 = fan
    wire = fan200["flat"].image.copy()
    figure("failure_06_slivers.png",
           [("img", grid["phong"].image, "8 x 8 grid, Phong"), ("img", wire, "200 slivers, flat"),
            ("img", fan200["gouraud"].image, "200 slivers, Gouraud"), ("img", fan200["phong"].image, "200 slivers, Phong")],
           "6. Sliver triangles: coverage and Phong unchanged; flat and Gouraud sample far from the pixel")

    ico, flipped, _ = fs.flipped_sphere()
    faces = flipped.faces
    sphere_scene = fs.sphere_scene
    exact = exact_for_scene(sphere_scene(ico), [Sphere()])
    cases = {"consistent, computed": rs.Mesh(ico.vertices, ico.faces),
             "30% flipped, computed": rs.Mesh(ico.vertices, faces),
             "30% flipped, given": rs.Mesh(ico.vertices, faces, normals=ico.normals)}
    tm = trimesh.Trimesh(ico.vertices, faces, process=False)
    trimesh.repair.fix_winding(tm)
    cases["flipped, fix_winding"] = rs.Mesh(tm.vertices, tm.faces)
    out = {}
    for name, mesh in cases.items():
        f = _all(sphere_scene(mesh))
        out[name] = f
        for m in rs.SHADINGS:
            c = compare(exact, f[m], use_ssim=False)
            record(6, f"winding {name}: {m} RMSE", c.rmse)
            record(6, f"winding {name}: {m} p95 normal error (deg)", c.p95_angle)
    figure("failure_06_winding.png",
           [("img", out["30% flipped, computed"]["flat"].image, "flipped: flat"),
            ("img", out["30% flipped, computed"]["phong"].image, "flipped, computed n: Phong"),
            ("img", out["30% flipped, given"]["gouraud"].image, "flipped, given n: Gouraud"),
            ("img", out["30% flipped, given"]["phong"].image, "flipped, given n: Phong"),
            ("img", out["flipped, fix_winding"]["phong"].image, "after fix_winding: Phong")],
           "6. Inconsistent winding (30% of the faces)", width=2.1)

    ico2 = rs.shapes.icosphere(2, radius=0.9)
    soup_v = ico2.vertices[ico2.faces].reshape(-1, 3)
    soup = _all(sphere_scene(rs.Mesh(soup_v, np.arange(len(soup_v)).reshape(-1, 3))))
    welded = _all(sphere_scene(rs.Mesh(ico2.vertices, ico2.faces)))
    record(6, "unwelded: phong normal = flat normal (max diff)", np.abs(soup["phong"].normal - soup["flat"].normal).max())
    record(6, "unwelded vs welded phong, max", np.abs(soup["phong"].image - welded["phong"].image).max())


# -- 7 -------------------------------------------------------------------------------------------------

def case_7():
    items = []
    for t in (0.5, 1e6):
        scene = fs.shininess_scene(t)
        fr = rs.render(scene, "phong")
        s = -scene.lights[0].direction
        dark = (fs.dot(fr.normal.astype(np.float64), s) <= -1e-6) & fr.mask
        record(7, f"t = {t:g}: max |I - ambient| where n.s <= 0", np.abs(fr.image[dark] - 0.1).max())
        items.append(("img", fr.image, f"sphere, t = {t:g}"))
    pscene = fs.needle_scene()
    exact = exact_for_scene(pscene, [Plane(size=4.0)])
    f = _all(pscene)
    record(7, "t = 1e6 plane: exact pixels > 1e-3", (exact.image[..., 0] > 1e-3).sum())
    for m in rs.SHADINGS:
        record(7, f"t = 1e6 plane: {m} pixels > 1e-3", (f[m].image[..., 0] > 1e-3).sum())
    record(7, "t = 1e6 plane: phong vs exact max", np.abs(f["phong"].image - exact.image).max())
    items += [("img", exact.image, "t = 1e6: exact (1 pixel)"), ("img", f["gouraud"].image, "Gouraud: a star"),
              ("img", f["phong"].image, "Phong (1 pixel)")]
    figure("failure_07_shininess.png", items, "7. Extreme shininess: t = 0.5 and t = 1e6", width=2.1)


# -- 8 -------------------------------------------------------------------------------------------------

def case_8():
    where = fs.light_positions()
    items = []
    for att in ("none", "inverse_square", "heuristic"):
        scene = fs.light_sphere_scene(where["vertex"], att)
        f = _all(scene)
        for m in rs.SHADINGS:
            record(8, f"light on vertex, {att}: {m} peak (outside)", f[m].image.max())
        if att == "inverse_square":
            items += [("img", f["flat"].image, "on a vertex: flat"), ("img", f["phong"].image, "Phong: leak (exp. 1)"),
                      ("img", f["phong"].image, "Phong (exposure 1/300)", 1 / 300)]
        inner = fs.light_sphere_scene(where["inside"], att)
        fi = rs.render(inner, "phong")
        record(8, f"light inside, {att}: phong max |I - ambient| outside", np.abs(fi.image[fi.mask] - 0.1).max())
        if att == "inverse_square":
            items.append(("img", rs.render(inner.replace(camera=fs.INSIDE_CAMERA), "phong").image, "light inside, seen inside"))
    figure("failure_08_light.png", items, "8. A point light on a vertex (inverse square) and inside the sphere",
           width=2.1)


# -- 9 -------------------------------------------------------------------------------------------------

def case_9():
    from raycast_shade.visibility import embree as _embree
    from raycast_shade.visibility import holes as cast_mod  # the camera's re-test lives in holes

    items = []
    saved_flag, saved_jitter = _embree._RTC_SCENE_FLAG_ROBUST, cast_mod._JITTER
    try:
        for label, eye, fov in (("near", (0.3, -1.2, 2.5), 50.0), ("far", (3.0, -40.0, 50.0), 2.0)):
            cam = fs.pixel_ray_camera(eye, fov)
            for step in (1, 2, 3):
                mesh = fs.grid_at_pixel_rays(cam, step)
                for name, flag, jitter in (("default flags", 0, ()), ("robust", saved_flag, ()),
                                           ("robust + re-cast", saved_flag, saved_jitter)):
                    _embree._RTC_SCENE_FLAG_ROBUST = flag
                    cast_mod._JITTER = jitter
                    scene = fs.scene([rs.Model(mesh, rs.Material(kd=0.8))], [rs.DirectionalLight((0.2, -0.3, -1.0))], cam,
                                   0.1)
                    fr = rs.render(scene, "flat")
                    record(9, f"grid at pixel rays, {label}, step {step}, {name}: misses", (~fr.mask).sum())
                    if label == "near" and step == 1:
                        img = fr.image.copy()
                        img[~fr.mask] = (1.0, 0.0, 0.0)
                        items.append(("img", img, f"{name}: {(~fr.mask).sum()} misses"))
    finally:
        _embree._RTC_SCENE_FLAG_ROBUST, cast_mod._JITTER = saved_flag, saved_jitter
    # From inside a closed sphere.
    misses = 0
    for mesh in (rs.shapes.icosphere(3), rs.shapes.uv_sphere(16, 32)):
        for cam in fs.inside_cameras(mesh, projections=("perspective",)):
            misses += int((~rs.render(fs.scene(mesh, [], cam), "flat").mask).sum())
    record(9, "inside closed spheres (26 views): misses", misses)
    figure("failure_09_holes.png", items, "9. Every ray through a vertex of a grid (perspective, 128 x 96): misses in red",
           width=2.6)
    vertex_figure()


def vertex_figure():
    """Rays that slip through a vertex and see what lies behind: the grid of case 9
    with a plane 1 below it (pixels showing the plane in red), before and after
    the depth-jump re-test; and rays from one eye at every vertex of icosphere(5)
    (leaks through to the far side in red), Embree alone and ``watertight``.
    Figures: benchmarks/vertex_rays.py."""
    from raycast_shade.visibility import holes

    items = []
    cam = fs.pixel_ray_camera((3.0, -40.0, 50.0), 2.0)
    floor = rs.shapes.plane(size=400.0, center=(0.0, 0.0, -1.0), normal="+z")
    scene = fs.scene([rs.Model(fs.grid_at_pixel_rays(cam, 1), rs.Material(kd=0.8)), rs.Model(floor, rs.Material(kd=0.8))],
                   [rs.DirectionalLight((0.2, -0.3, -1.0))], cam, 0.1)
    saved = holes._JUMP
    try:
        for name, jump in (("misses re-cast (before)", np.inf), ("+ depth-jump re-test", saved)):
            holes._JUMP = jump
            fr = rs.render(scene, "flat")
            img = fr.image.copy()
            img[fr.hits.geom == 1] = (1.0, 0.0, 0.0)
            items.append(("img", img, f"{name}: {(fr.hits.geom == 1).sum()} see the plane"))
    finally:
        holes._JUMP = saved
    mesh = rs.shapes.icosphere(5)
    sph = rs.Scene([rs.Model(mesh)])
    eye = np.array([2.4, 1.6, 2.8])
    front = np.einsum("ij,ij->i", mesh.normals, eye - mesh.vertices) > 0
    target = mesh.vertices[front]
    d = target - eye
    dist = np.linalg.norm(d, axis=1)
    d /= dist[:, None]
    # Screen coordinates of the vertices, seen from the eye.
    fwd = -eye / np.linalg.norm(eye)
    right = fs.unit(np.cross(fwd, (0.0, 1.0, 0.0)))
    up = np.cross(right, fwd)
    sx, sy = d @ right / (d @ fwd), d @ up / (d @ fwd)
    for wt in (False, True):
        hits = rs.cast_rays(sph, np.broadcast_to(eye, d.shape).copy(), d, watertight=wt)
        leak = (hits.prim >= 0) & (hits.t > dist * (1 + 1e-4))

        def plot(ax, leak=leak):
            ax.scatter(sx[~leak], sy[~leak], s=0.3, c="0.6", lw=0)
            ax.scatter(sx[leak], sy[leak], s=6, c="red", lw=0)
            ax.set_aspect("equal")
            ax.set_xticks([])
            ax.set_yticks([])

        items.append(("plot", plot, f"{'watertight' if wt else 'Embree alone'}: {leak.sum()} of {len(d)} leak"))
    figure("failure_09_vertex.png", items, "9b. Rays through vertices that slip through: the plane behind a vertex grid "
           "(left), the far side of icosphere(5) (right), in red", width=2.6)


# -- 10 ------------------------------------------------------------------------------------------------

def case_10():
    base = rs.render(fs.far_scene((0.0, 0.0, 0.0)), "phong")
    items = [("img", base.image, "at the origin")]
    for shift in (1e3, 1e5, 1e7):
        off = shift * np.array([1.0, -0.7, 0.4])
        for m in rs.SHADINGS:
            a = rs.render(fs.far_scene((0.0, 0.0, 0.0)), m)
            b = rs.render(fs.far_scene(off), m)
            record(10, f"shift {shift:g}, {m}: pixels changing triangle", (a.hits.prim != b.hits.prim).sum())
            record(10, f"shift {shift:g}, {m}: max image difference", np.abs(a.image - b.image).max())
        q = rs.render(fs.far_scene(off, quantise=True), "phong")
        record(10, f"shift {shift:g}: float32 vertices at the offset, RMSE", rmse(base.image, q.image))
        record(10, f"shift {shift:g}: float32 vertices at the offset, max", np.abs(base.image - q.image).max())
        if shift == 1e5:
            q5 = q
        if shift == 1e7:
            moved = rs.render(fs.far_scene(off), "phong")
            items += [("img", moved.image, "at 1e7 (ours)"),
                      ("img", np.abs(moved.image - base.image) * 1e6, "|difference| x 1e6"),
                      ("img", q5.image, "float32 vertices at 1e5"),
                      ("img", np.abs(q5.image - base.image) * 10, "|difference| x 10")]
    figure("failure_10_far.png", items, "10. The same scene far from the origin, with shadows", width=2.1)


# -- 11 ------------------------------------------------------------------------------------------------

def case_11():
    es = np.concatenate([-np.logspace(-8, -1, 15)[::-1], [0.0], np.logspace(-8, -1, 15)])
    vals = {m: [] for m in rs.SHADINGS}
    for e in es:
        for m in rs.SHADINGS:
            fr = rs.render(fs.grazing_light_scene(e), m)
            vals[m].append(fr.image[fr.mask].mean())
    pos = es > 0
    record(11, "lambert: max |I / (kd sin e) - 1| for e > 0",
           max(np.abs(np.array(vals[m])[pos] / (0.8 * np.sin(es[pos])) - 1).max() for m in rs.SHADINGS))
    record(11, "lambert max |I - kd sin e| over the sweep",
           max(np.abs(np.array(vals[m]) - 0.8 * np.maximum(0, np.sin(es))).max() for m in rs.SHADINGS))
    # Terminator.
    scene = fs.terminator_scene()
    term = {}
    for m in rs.SHADINGS:
        fr = rs.render(scene, m)
        img = fr.image[..., 0]
        dark = fr.mask & (img == 0)
        near = np.zeros_like(dark)
        near[:, 1:] |= dark[:, :-1]
        near[:, :-1] |= dark[:, 1:]
        near[1:] |= dark[:-1]
        near[:-1] |= dark[1:]
        border = fr.mask & ~dark & near
        record(11, f"terminator: brightest lit pixel next to an unlit one, {m}", img[border].max())
        term[m] = fr.image
    # Specular switch-off at grazing light, eye in the mirror direction.
    le = np.linspace(-0.02, 0.02, 41)
    spec = []
    for e in le:
        fr = rs.render(fs.specular_switch_scene(e), "phong")
        spec.append(fr.image[fr.mask].max())
    spec = np.array(spec)
    record(11, "specular just above the horizon (e = +1e-3 rad)", spec[np.argmin(np.abs(le - 1e-3))])
    record(11, "specular just below the horizon", spec[le < 0].max())
    # Grazing view.
    worst = 0.0
    for deg in (5.0, 0.05, 0.0005):
        vs = fs.grazing_view_scene(deg)
        ex = exact_for_scene(vs, [Plane(size=4.0)])
        fr = rs.render(vs, "phong")
        worst = max(worst, np.abs(fr.image - ex.image).max())
        if deg == 0.0005:
            graze = fr.image
    record(11, "grazing view (5 to 0.0005 deg): max error vs exact plane", worst)

    def lam(ax):
        pos = es > 0
        ax.loglog(es[pos], np.array(vals["phong"])[pos], "o", ms=3, label="rendered")
        ax.loglog(es[pos], 0.8 * np.sin(es[pos]), "k-", lw=0.8, label="kd sin e")
        ax.set_xlabel("light elevation e (rad)", fontsize=6)
        ax.legend(fontsize=6)

    def sw(ax):
        ax.plot(le, spec, "o-", ms=2)
        ax.set_xlabel("light elevation (rad)", fontsize=6)
        ax.set_ylabel("peak specular", fontsize=6)

    figure("failure_11_grazing.png",
           [("plot", lam, "Lambert term to 0"), ("img", term["flat"], "terminator: flat"),
            ("img", term["phong"], "terminator: Phong"), ("plot", sw, "specular at grazing light"),
            ("img", graze, "eye 0.0005 deg above a plane")],
           "11. Grazing light and grazing view", width=2.2)


CASES = {1: case_1, 2: case_2, 3: case_3, 4: case_4, 5: case_5, 6: case_6_degenerate, 7: case_7, 8: case_8, 9: case_9,
         10: case_10, 11: case_11}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--only", type=int, nargs="*", help="case numbers (default: all)")
    ap.add_argument("--quick", action="store_true", help="write into the git-ignored quick/ folders")
    args = ap.parse_args(argv)
    global IMAGES, RESULTS
    IMAGES, RESULTS = images_dir(args.quick), results_dir(args.quick)
    todo = args.only or sorted(CASES)
    for k in todo:
        print(f"case {k}")
        CASES[k]()
    os.makedirs(RESULTS, exist_ok=True)
    path = os.path.join(RESULTS, "failure_cases.csv")
    old = []
    if args.only and os.path.exists(path):
        with open(path) as fh:
            old = [r for r in csv.reader(fh)][1:]
        old = [r for r in old if int(r[0]) not in todo]
    with open(path, "w", newline="") as fh:
        wr = csv.writer(fh)
        wr.writerow(["case", "quantity", "value"])
        for r in sorted(old + [[str(c), n, f"{v:.6g}"] for c, n, v in ROWS], key=lambda r: int(r[0])):
            wr.writerow(r)
    print(f"  -> {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
