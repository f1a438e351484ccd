"""The paper's start for implicit surfaces (Sec. 5.5): a tessellated sphere around the object,
which the fit deforms into its shape (with the absolute Laplacian, ``TexturedMesh``)."""

from __future__ import annotations

import math

import torch

from ..asset.mesh import Mesh
from ..asset.subdivide import subdivide
from .decimate import decimate

GOLDEN = (1.0 + math.sqrt(5.0)) / 2.0
ICOSAHEDRON_VERTICES = [(-1, GOLDEN, 0), (1, GOLDEN, 0), (-1, -GOLDEN, 0), (1, -GOLDEN, 0), (0, -1, GOLDEN),
                        (0, 1, GOLDEN), (0, -1, -GOLDEN), (0, 1, -GOLDEN), (GOLDEN, 0, -1), (GOLDEN, 0, 1),
                        (-GOLDEN, 0, -1), (-GOLDEN, 0, 1)]
ICOSAHEDRON_FACES = [(0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11), (1, 5, 9), (5, 11, 4), (11, 10, 2),
                     (10, 7, 6), (7, 1, 8), (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8), (3, 8, 9), (4, 9, 5),
                     (2, 4, 11), (6, 2, 10), (8, 6, 7), (9, 8, 1)]
"""The regular icosahedron, faces counter-clockwise seen from outside."""


def tessellated_sphere(centre: torch.Tensor, radius: float, triangles: int) -> Mesh:
    """A sphere of ``radius`` about ``centre [3]`` with about ``triangles`` triangles: the
    icosahedron subdivided (1 -> 4, each new vertex pushed onto the sphere) until it has at
    least that many, then decimated to the count."""
    mesh = Mesh(v_pos=torch.tensor(ICOSAHEDRON_VERTICES, dtype=torch.float32),
                t_pos_idx=torch.tensor(ICOSAHEDRON_FACES, dtype=torch.int64))
    while mesh.num_triangles < triangles:
        mesh = subdivide(mesh)
        mesh = Mesh(v_pos=mesh.v_pos / mesh.v_pos.norm(dim=-1, keepdim=True), t_pos_idx=mesh.t_pos_idx)
    unit = mesh.v_pos / mesh.v_pos.norm(dim=-1, keepdim=True)
    sphere = Mesh(v_pos=torch.as_tensor(centre, dtype=torch.float32) + radius * unit, t_pos_idx=mesh.t_pos_idx)
    return sphere if sphere.num_triangles <= triangles else decimate(sphere, triangles)
