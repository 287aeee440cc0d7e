"""Write ``meshes/knot.obj``: a coarse tube around a trefoil knot.

The mesh used by ``knot.toml``, generated with NumPy alone so that it can be
rebuilt anywhere::

    python examples/make_knot.py

The tube is a closed grid of ``SEGMENTS`` rings of ``SIDES`` vertices, with
no duplicated seam, so that computed vertex normals are smooth all round.
The file holds positions and faces only: the renderer averages the normals.
"""

from __future__ import annotations

import os

import numpy as np

SEGMENTS = 120  # rings along the knot
SIDES = 10  # vertices around the tube: coarse, so the shading modes differ
TUBE_RADIUS = 0.42


def trefoil(t: np.ndarray) -> np.ndarray:
    """Centre line of the trefoil knot, about 6 units across, in the xy plane."""
    return np.stack([np.sin(t) + 2 * np.sin(2 * t), np.cos(t) - 2 * np.cos(2 * t), -np.sin(3 * t)], axis=-1)


def knot_mesh(segments: int = SEGMENTS, sides: int = SIDES, radius: float = TUBE_RADIUS):
    """Vertices (segments * sides, 3) and counter-clockwise faces (2 * segments * sides, 3)."""
    t = np.linspace(0.0, 2 * np.pi, segments, endpoint=False)
    c = trefoil(t)
    # Central differences on the closed curve give the tangent.
    tangent = np.roll(c, -1, axis=0) - np.roll(c, 1, axis=0)
    tangent /= np.linalg.norm(tangent, axis=1, keepdims=True)
    # The tangent is never parallel to z on this knot, so z gives a smooth,
    # periodic frame (no twist to close at the seam).
    normal = np.cross(tangent, [0.0, 0.0, 1.0])
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    binormal = np.cross(tangent, normal)
    a = np.linspace(0.0, 2 * np.pi, sides, endpoint=False)
    ring = np.cos(a)[None, :, None] * normal[:, None, :] + np.sin(a)[None, :, None] * binormal[:, None, :]
    vertices = (c[:, None, :] + radius * ring).reshape(-1, 3)
    i, j = np.meshgrid(np.arange(segments), np.arange(sides), indexing="ij")
    p00 = i * sides + j
    p10 = ((i + 1) % segments) * sides + j
    p01 = i * sides + (j + 1) % sides
    p11 = ((i + 1) % segments) * sides + (j + 1) % sides
    faces = np.concatenate([np.stack([p00, p10, p11], -1).reshape(-1, 3), np.stack([p00, p11, p01], -1).reshape(-1, 3)])
    # Make the winding face outwards (away from the centre line).
    v0, v1, v2 = (vertices[faces[:, k]] for k in range(3))
    outward = (v0 + v1 + v2) / 3 - c[faces[:, 0] // sides]
    if np.einsum("ij,ij->i", np.cross(v1 - v0, v2 - v0), outward).sum() < 0:
        faces = faces[:, ::-1]
    return vertices, faces


def write_obj(path: str, vertices: np.ndarray, faces: np.ndarray) -> None:
    with open(path, "w", encoding="ascii") as fh:
        fh.write(f"# trefoil knot tube, {len(vertices)} vertices, {len(faces)} triangles (examples/make_knot.py)\n")
        fh.writelines(f"v {x:.5f} {y:.5f} {z:.5f}\n" for x, y, z in vertices)
        fh.writelines(f"f {a + 1} {b + 1} {c + 1}\n" for a, b, c in faces)  # OBJ counts from 1


if __name__ == "__main__":
    here = os.path.dirname(os.path.abspath(__file__))
    out = os.path.join(here, "meshes", "knot.obj")
    os.makedirs(os.path.dirname(out), exist_ok=True)
    v, f = knot_mesh()
    write_obj(out, v, f)
    print(f"wrote {out}: {len(v)} vertices, {len(f)} triangles, {os.path.getsize(out) // 1024} KB")
