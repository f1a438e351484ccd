"""The sampled two-sided surface distance: its figures against the brute-force twin, and what
each direction sees."""

from __future__ import annotations

import numpy as np
import pytest
from mesh_factory import icosphere

from lookalike.init.surface_distance import (FAR, OneWay, SurfaceGauge, bounding_radius, guard_points,
                                             surface_distance, surface_distance_python)


def _arrays(mesh):
    return mesh.v_pos.double().numpy(), mesh.t_pos_idx.numpy()


def test_the_gauge_matches_its_brute_force_twin():
    """A coarse sphere against a fine one, and a sphere that lost a part: the same samples,
    the same closest distances, the same figures."""
    fine_pos, fine_idx = _arrays(icosphere(3))
    coarse_pos, coarse_idx = _arrays(icosphere(1))
    other_pos, other_idx = _arrays(icosphere(2, center=(2.5, 0.0, 0.0), radius=0.4))
    two_pos = np.concatenate([fine_pos, other_pos])
    two_idx = np.concatenate([fine_idx, other_idx + len(fine_pos)])
    for input_mesh, low in [((fine_pos, fine_idx), (coarse_pos, coarse_idx)),
                            ((two_pos, two_idx), (coarse_pos, coarse_idx))]:
        exact = surface_distance(*input_mesh, *low, samples=1500, seed=3, beyond=np.inf)
        bounded = surface_distance(*input_mesh, *low, samples=1500, seed=3)     # upper bounds past BEYOND
        slow = surface_distance_python(*input_mesh, *low, samples=1500, seed=3)
        for direction in ("low_to_input", "input_to_low"):
            a, b, c = getattr(exact, direction), getattr(slow, direction), getattr(bounded, direction)
            assert a.mean == pytest.approx(b.mean, rel=1e-9, abs=1e-15)
            assert a.p99 == pytest.approx(b.p99, rel=1e-9, abs=1e-15)
            assert a.far_area == b.far_area == c.far_area
            assert b.mean - 1e-12 <= c.mean <= b.mean + 0.1 and b.p99 - 1e-12 <= c.p99
    # the lost part is far from the low mesh, never the other way round
    lost = surface_distance(two_pos, two_idx, *_arrays(icosphere(2)), samples=4000)
    assert lost.low_to_input.far_area == 0.0
    share = 4 * np.pi * 0.4 ** 2 / (4 * np.pi * (1 + 0.4 ** 2))        # the small sphere's share of the area
    assert lost.input_to_low.far_area == pytest.approx(share, abs=0.02)
    assert lost.combined.far_area == lost.input_to_low.far_area


def test_a_shard_is_seen_mostly_from_the_low_mesh():
    pos, idx = _arrays(icosphere(3))
    low = pos.copy()
    low[0] *= 1.5                                   # one vertex pulled out: a spike of shards
    distance = SurfaceGauge(pos, idx, samples=20_000).measure(low, idx)
    # the spike is far from the input; the input under it is uncovered, over a smaller area
    assert distance.low_to_input.far_area > 3 * distance.input_to_low.far_area > 0
    assert distance.as_dict()["far_area"] == distance.low_to_input.far_area
    assert set(distance.as_dict()) == {"mean", "p99", "far_area", "low_to_input", "input_to_low", "far"}


def test_figures_are_in_bounding_radii_and_repeat():
    pos, idx = _arrays(icosphere(2, radius=3.0))
    shifted = pos + [0.3, 0.0, 0.0]                 # 10 % of the radius away everywhere, at most
    first = surface_distance(pos, idx, shifted, idx, samples=3000, seed=1)
    assert bounding_radius(pos, idx) == pytest.approx(3.0, rel=1e-6)
    assert 0.0 < first.combined.mean <= 0.1 + 1e-9 and first.combined.far_area > 0.5
    assert surface_distance(pos, idx, shifted, idx, samples=3000, seed=1) == first
    assert OneWay.of(np.array([0.0, 2 * FAR]), 1.0).far_area == 0.5


def test_triangle_distances_take_the_farthest_of_seven_points():
    pos, idx = _arrays(icosphere(3))
    gauge = SurfaceGauge(pos, idx, samples=100)
    # a triangle spanning the sphere's inside: corners on the surface, its middle far from it
    chord = np.array([[1.0, 0.0, 0.0], [-0.5, 0.8660254, 0.0], [-0.5, -0.8660254, 0.0]])
    points = guard_points(chord, np.array([[0, 1, 2]]))
    assert points.shape == (1, 7, 3)
    assert gauge.triangle_distances(chord, np.array([[0, 1, 2]]))[0] == pytest.approx(1.0, abs=0.02)
