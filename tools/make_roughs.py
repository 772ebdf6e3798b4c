"""Make the bundled roughs of meshes/rough/ (deterministic; run from the repository root):

    .venv/bin/python tools/make_roughs.py

* ``slab-40x30x6.ply``: a sawn slab, 40 x 30 x 6 mm, spanning [0, 40] x [0, 30] x [0, 6].
* ``nodule-convex.ply``: a convex nodule about 42 x 30 x 22 mm: the convex hull of 400 points on
  an ellipsoid pushed in and out by up to 12 % (seed 7), as a tumbled nodule is.
* ``nodule-dented.ply``: a non-convex nodule: the same kind of hull (seed 11) with a bite taken
  out of one side (a sphere of radius 11 mm, manifold3d difference), as a broken-off rough is.
"""

from __future__ import annotations

from pathlib import Path

import manifold3d
import numpy as np
import trimesh

OUT = Path(__file__).resolve().parents[1] / "meshes" / "rough"


def nodule(seed: int, radii: tuple[float, float, float]) -> trimesh.Trimesh:
    rng = np.random.default_rng(seed)
    d = rng.normal(size=(400, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    pts = d * np.asarray(radii) * rng.uniform(0.88, 1.12, size=(400, 1))
    hull = trimesh.convex.convex_hull(pts)
    hull.apply_translation(-hull.bounds[0])
    return hull


def main() -> None:
    OUT.mkdir(parents=True, exist_ok=True)
    slab = trimesh.creation.box(extents=(40.0, 30.0, 6.0))
    slab.apply_translation(np.array([20.0, 15.0, 3.0]))
    slab.export(OUT / "slab-40x30x6.ply")
    nodule(7, (21.0, 15.0, 11.0)).export(OUT / "nodule-convex.ply")
    body = nodule(11, (22.0, 16.0, 12.0))
    solid = manifold3d.Manifold(manifold3d.Mesh(vert_properties=body.vertices.astype(np.float32),
                                                tri_verts=body.faces.astype(np.uint32)))
    bite = manifold3d.Manifold.sphere(11.0, 64).translate((body.bounds[1][0] + 3.0, body.bounds[1][1] / 2.0,
                                                           body.bounds[1][2] / 2.0))
    out = (solid - bite).to_mesh()
    trimesh.Trimesh(np.asarray(out.vert_properties)[:, :3], np.asarray(out.tri_verts)).export(OUT / "nodule-dented.ply")


if __name__ == "__main__":
    main()
