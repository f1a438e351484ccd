"""Generated inputs on which decimation goes wrong in its own ways (``lookalike bench decimate``
and the tests): a hard-surface kit of a hundred open parts with UV seams, thin shells, a noisy
closed scan and a character of several closed, overlapping parts. Each is seeded and returns a
``Mesh`` stored as a file stores it: unwelded at its UV seams where it has UVs.
"""

from __future__ import annotations

import numpy as np
import torch

from ..asset import Mesh
from ..init.sphere_start import tessellated_sphere
from ..init.weld import weld_vertices


def _grid(n: int, m: int) -> tuple[np.ndarray, np.ndarray]:
    """``(uv [(n+1)(m+1), 2], triangles [2nm, 3])`` of an ``n x m``-quad grid over the unit
    square, counter-clockwise seen from +z."""
    u, v = np.meshgrid(np.linspace(0, 1, n + 1), np.linspace(0, 1, m + 1), indexing="ij")
    uv = np.stack([u.ravel(), v.ravel()], axis=1)
    i, j = np.meshgrid(np.arange(n), np.arange(m), indexing="ij")
    a = (i * (m + 1) + j).ravel()
    b, c, d = a + m + 1, a + 1, a + m + 2
    return uv, np.concatenate([np.stack([a, b, c], 1), np.stack([c, b, d], 1)])


def _rotation(rng: np.random.Generator) -> np.ndarray:
    """A uniformly random rotation ``[3, 3]``."""
    q, r = np.linalg.qr(rng.normal(size=(3, 3)))
    q = q * np.sign(np.diag(r))
    return q if np.linalg.det(q) > 0 else -q


class _Charts:
    """Positions, triangles and UVs gathered chart by chart, each chart its own vertices (a UV
    seam between charts), each chart's UVs in its own cell of a square atlas."""

    def __init__(self):
        self.pos, self.tri, self.uv = [], [], []
        self.count = 0

    def add(self, pos: np.ndarray, tri: np.ndarray, uv: np.ndarray) -> None:
        self.pos.append(pos)
        self.tri.append(tri + sum(len(p) for p in self.pos[:-1]))
        self.uv.append(uv)
        self.count += 1

    def mesh(self) -> Mesh:
        side = int(np.ceil(np.sqrt(self.count)))
        uv = np.concatenate([(0.05 + 0.9 * u + [k % side, k // side]) / side for k, u in enumerate(self.uv)])
        tri = torch.as_tensor(np.concatenate(self.tri), dtype=torch.int64)
        return Mesh(v_pos=torch.as_tensor(np.concatenate(self.pos), dtype=torch.float32), t_pos_idx=tri,
                    uv=[(torch.as_tensor(uv, dtype=torch.float32), tri)])


def _open_box(charts: _Charts, rng, place) -> None:
    """A box of random sides with its top face missing, each face a 4 x 4 chart."""
    size = rng.uniform(0.1, 0.4, 3)
    uv, tri = _grid(4, 4)
    s = uv - 0.5
    faces = [(s[:, 0], s[:, 1], np.full(len(s), -0.5), True),     # bottom (-z), faces out
             (s[:, 0], np.full(len(s), -0.5), s[:, 1], False), (s[:, 0], np.full(len(s), 0.5), s[:, 1], True),
             (np.full(len(s), -0.5), s[:, 0], s[:, 1], True), (np.full(len(s), 0.5), s[:, 0], s[:, 1], False)]
    for x, y, z, flip in faces:
        charts.add(place(np.stack([x, y, z], 1) * size), tri[:, ::-1] if flip else tri, uv)


def _plate(charts: _Charts, rng, place) -> None:
    """An open sheet of random sides, gently bent, one 8 x 8 chart."""
    size = rng.uniform(0.2, 0.6, 2)
    uv, tri = _grid(8, 8)
    s = (uv - 0.5) * size
    bend = rng.uniform(-0.3, 0.3)
    charts.add(place(np.stack([s[:, 0], s[:, 1], bend * s[:, 0] ** 2], 1)), tri, uv)


def _pipe(charts: _Charts, rng, place) -> None:
    """An open tube, 12 sides around and 6 along, one chart cut along its length."""
    radius, length = rng.uniform(0.03, 0.08), rng.uniform(0.3, 0.8)
    uv, tri = _grid(12, 6)
    angle = 2 * np.pi * uv[:, 0]
    charts.add(place(np.stack([radius * np.cos(angle), radius * np.sin(angle), length * (uv[:, 1] - 0.5)], 1)),
               tri, uv)


def hard_surface_kit(parts: int = 100, seed: int = 0, extent: float = 1.0) -> Mesh:
    """A hundred open parts of a hard-surface kit (open boxes, bent plates, open pipes) at random
    places and orientations within ``[-extent, extent]^3``, each face its own UV chart: about
    14,000 triangles, mostly open border, unwelded at every seam."""
    rng = np.random.default_rng(seed)
    charts = _Charts()
    makers = (_open_box, _plate, _pipe)
    for _ in range(parts):
        rotation, offset = _rotation(rng), rng.uniform(-extent, extent, 3)
        makers[int(rng.integers(3))](charts, rng, lambda p: p @ rotation.T + offset)
    return charts.mesh()


def _mesh(v: np.ndarray, f: np.ndarray) -> Mesh:
    return Mesh(v_pos=torch.as_tensor(v, dtype=torch.float32), t_pos_idx=torch.as_tensor(f, dtype=torch.int64))


def noisy_sphere(triangles: int = 20_000, seed: int = 0, roughness: float = 0.08) -> Mesh:
    """A scan-like closed surface of about ``triangles`` triangles (``12 n^2``): a cube's six
    faces, each ``n x n`` quads, pushed onto the unit sphere and welded, then displaced along the
    radius by a sum of random waves of falling amplitude (``roughness`` of the radius at the
    coarsest) and fine noise on every vertex, as a scan's."""
    rng = np.random.default_rng(seed)
    n = max(1, round(np.sqrt(triangles / 12)))
    uv, quads = _grid(n, n)
    s = 2 * uv - 1
    pos, tri = [], []
    for axis in range(3):
        for sign in (1.0, -1.0):
            face = np.insert(s[:, ::-1] if sign < 0 else s, axis, sign, axis=1)
            tri.append(quads + sum(len(p) for p in pos))
            pos.append(face)
    v, f, _ = weld_vertices(np.concatenate(pos), np.concatenate(tri), 1e-9)
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    outward = np.einsum("ij,ij->i", np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]]), v[f].mean(axis=1))
    f = np.where((outward < 0)[:, None], f[:, ::-1], f)
    height = np.zeros(len(v))
    for octave in range(5):
        frequency = 2.0 * 2 ** octave
        direction = rng.normal(size=(4, 3))
        phase = rng.uniform(0, 2 * np.pi, 4)
        height += roughness / 2 ** octave * np.sin(frequency * v @ direction.T + phase).mean(axis=1)
    height += 0.002 * rng.normal(size=len(v))
    return _mesh(v * (1 + height)[:, None], f)


def thin_shells(seed: int = 0) -> Mesh:
    """Two thin shells side by side: a closed box 1 x 1 x 0.01, each face tessellated, and a
    two-sided plate: two opposite sheets 0.004 apart, not connected (a card with a back)."""
    rng = np.random.default_rng(seed)
    pos, tri = [], []

    def add(v, f):
        tri.append(f + sum(len(p) for p in pos))
        pos.append(v)

    uv, quads = _grid(24, 24)
    s = uv - 0.5
    for z, flip in ((0.005, False), (-0.005, True)):                 # the box's two large faces
        add(np.stack([s[:, 0], s[:, 1], np.full(len(s), z)], 1), quads[:, ::-1] if flip else quads)
    rim_uv, rim = _grid(24, 1)
    for axis, sign in ((0, 1), (0, -1), (1, 1), (1, -1)):            # its four thin sides
        t, h = rim_uv[:, 0] - 0.5, (rim_uv[:, 1] - 0.5) * 0.01
        side = np.stack([np.full(len(t), 0.5 * sign), t, h], 1) if axis == 0 else \
            np.stack([t, np.full(len(t), 0.5 * sign), h], 1)
        add(side, rim if (sign > 0) == (axis == 0) else rim[:, ::-1])
    wave = 0.02 * np.sin(3 * s[:, 0]) * np.cos(2 * s[:, 1])
    for z, flip in ((0.002, False), (-0.002, True)):                 # the two-sided plate
        add(np.stack([s[:, 0] + 1.3, s[:, 1], wave + z], 1), quads[:, ::-1] if flip else quads)
    v = np.concatenate(pos) @ _rotation(rng).T
    return _mesh(v, np.concatenate(tri))


def character(seed: int = 0) -> Mesh:
    """A character-like shape of several closed parts that overlap where they join: a body, a
    head, two eyes, two arms and two legs, each an ellipsoid of 1,280 or 5,120 triangles,
    slightly noisy."""
    rng = np.random.default_rng(seed)
    parts = [((0, 0, 0), (0.35, 0.25, 0.5), 4), ((0, 0, 0.7), (0.22, 0.22, 0.25), 4),
             ((-0.08, 0.19, 0.75), (0.05, 0.04, 0.05), 3), ((0.08, 0.19, 0.75), (0.05, 0.04, 0.05), 3),
             ((-0.45, 0, 0.1), (0.28, 0.08, 0.08), 3), ((0.45, 0, 0.1), (0.28, 0.08, 0.08), 3),
             ((-0.15, 0, -0.75), (0.1, 0.1, 0.4), 3), ((0.15, 0, -0.75), (0.1, 0.1, 0.4), 3)]
    pos, tri = [], []
    for centre, radii, subdivisions in parts:
        sphere = tessellated_sphere(torch.zeros(3), 1.0, 20 * 4 ** subdivisions)
        v, f = sphere.v_pos.double().numpy(), sphere.t_pos_idx.numpy()
        v = v * (1 + 0.01 * rng.normal(size=(len(v), 1))) * radii + centre
        tri.append(f + sum(len(p) for p in pos))
        pos.append(v)
    return _mesh(np.concatenate(pos), np.concatenate(tri))
