"""Mesh-quality provenance: counts, topology, distributions, valence, normal variation
(diagnostic only) and the advisory rules."""
import numpy as np
import pytest

from hullprod_wb.core.constants import METRICS
from hullprod_wb.examples.analytic_meshes import (cylinder_mesh, grid_faces, icosphere_mesh, plane_mesh,
                                                  torus_mesh)
from hullprod_wb.mesh.backend import assess_mesh
from hullprod_wb.mesh.loading import mesh_from_arrays
from hullprod_wb.mesh.quality import mesh_quality, normal_variation, triangle_measures
from hullprod_wb.mesh.topology import edge_table, vertex_flags

DIST_KEYS = ("min", "p01", "p05", "median", "p95", "p99", "max")


def test_plane_grid_counts():
    n = 10
    V, F = plane_mesh(n, pattern="random")
    q = mesh_quality((V, F))
    assert q["counts"] == {"vertices": (n + 1) ** 2, "faces": 2 * n * n, "edges": 3 * n * n + 2 * n}
    assert q["boundary"]["edges"] == 4 * n and q["boundary"]["vertices"] == 4 * n
    assert q["boundary"]["edge_fraction"] == pytest.approx(4 * n / (3 * n * n + 2 * n))
    assert q["total_area"] == pytest.approx(4.0, rel=1e-14)
    assert q["connected_components"] == 1 and not q["watertight"]
    assert q["nonmanifold"]["edges"] == 0 and q["inconsistent_winding_edges"] == 0
    # right isosceles triangles: q = 4 sqrt(3) (1/2) / (1 + 1 + 2) = sqrt(3)/2, angles 45/90
    for k in DIST_KEYS:
        assert q["triangle_quality"][k] == pytest.approx(np.sqrt(3) / 2, rel=1e-12)
        assert q["min_angle_deg"][k] == pytest.approx(45.0, rel=1e-12)
        assert q["max_angle_deg"][k] == pytest.approx(90.0, rel=1e-12)
    assert q["normal_variation_deg"]["max"] == pytest.approx(0.0, abs=1e-12)
    assert q["advisory"] == "good" and q["reasons"] == []


def test_torus_is_watertight_with_regular_valence():
    V, F = torus_mesh(24)
    q = mesh_quality((V, F))
    assert q["watertight"] and q["boundary"]["edges"] == 0
    assert q["counts"]["edges"] == 3 * q["counts"]["vertices"]   # Euler: V - E + F = 0
    assert q["valence"]["histogram"] == {6: len(V)}               # consistent diagonals
    assert q["valence"]["interior_irregular_fraction"] == 0.0
    assert q["advisory"] in ("good", "caution")


def test_distributions_are_ordered():
    q = mesh_quality(icosphere_mesh(6, "random"))
    for name in ("triangle_quality", "min_angle_deg", "max_angle_deg", "edge_length", "vertex_area",
                 "normal_variation_deg"):
        d = [q[name][k] for k in DIST_KEYS]
        assert all(np.isfinite(d)) and d == sorted(d), name
    assert q["vertex_area"]["mean"] * q["counts"]["vertices"] == pytest.approx(q["total_area"], rel=1e-12)


def test_equilateral_quality_is_one():
    V = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.5, np.sqrt(3) / 2, 0.0]])
    area, qual, amin, amax = triangle_measures(V, np.array([[0, 1, 2]]))
    assert area[0] == pytest.approx(np.sqrt(3) / 4) and qual[0] == pytest.approx(1.0)
    assert amin[0] == pytest.approx(60.0) and amax[0] == pytest.approx(60.0)


def test_normal_variation_of_a_fold():
    """Two squares meeting at a right angle: the fold edges bend by 90 degrees."""
    x = np.linspace(0.0, 1.0, 5)
    X, Z = np.meshgrid(x, x, indexing="ij")
    floor = np.stack([X.ravel(), Z.ravel(), np.zeros(25)], axis=1)   # z = 0, (x, y)
    wall = np.stack([X.ravel(), np.zeros(25), Z.ravel()], axis=1)    # y = 0, (x, z)
    V = np.vstack([floor, wall])
    F = np.vstack([grid_faces(5, 5), grid_faces(5, 5)[:, ::-1] + 25])
    m = mesh_from_arrays(V, F)                                      # welds the shared fold line
    ang, pairs = normal_variation(np.asarray(m.vertices), np.asarray(m.faces))
    assert len(ang) == len(pairs)
    assert np.count_nonzero(np.isclose(ang, 90.0)) == 4              # the four fold segments
    assert np.allclose(ang[~np.isclose(ang, 90.0)], 0.0, atol=1e-12)
    q = mesh_quality(m)
    assert q["normal_variation_deg"]["above_30deg"] == 4
    assert q["advisory"] == "poor" and any("bend" in r for r in q["reasons"])


def test_sliver_mesh_is_poor():
    V, F = plane_mesh(8)
    V = V * [1.0, 0.02, 1.0]                                         # cells 50 times longer than wide
    q = mesh_quality((V, F))
    assert q["sliver_fraction"] == 1.0 and q["advisory"] == "poor"
    assert q["min_angle_deg"]["max"] < 5.0


def test_two_components_and_duplicates_caution():
    V1, F1 = cylinder_mesh(16, 8)
    V2, F2 = cylinder_mesh(16, 8)
    V = np.vstack([V1, V2 + [5.0, 0.0, 0.0]])
    F = np.vstack([F1, F2 + len(V1)])
    q = mesh_quality(mesh_from_arrays(V, F))
    assert q["connected_components"] == 2
    assert q["advisory"] in ("caution", "poor") and any("components" in r for r in q["reasons"])
    assert mesh_from_arrays(V, F).metadata["hullprod"]["pieces"] == 2


def test_vertex_flags_match_edge_table():
    V, F = cylinder_mesh(12, 5, pattern="random")
    boundary, nonmanifold = vertex_flags(F, len(V))
    t = edge_table(F, len(V))
    expect = np.zeros(len(V), bool)
    expect[t.edges[t.count == 1].ravel()] = True
    assert np.array_equal(boundary, expect) and not nonmanifold.any()
    assert boundary.sum() == 24 and np.all(t.count[t.side_edge] >= 1)


def test_quality_does_not_enter_the_signature():
    """The same geometry with the same connectivity gives the same values whatever the
    advisory thresholds say: quality only qualifies (status, evidence)."""
    import hullprod_wb.mesh.quality as Q
    V, F = torus_mesh(10, pattern="random")
    a = assess_mesh((V, F), lref=8.0, with_fields=False)
    old = Q.NORMAL_P99_CAUTION, Q.SHARP_EDGE_DEG
    try:
        Q.NORMAL_P99_CAUTION, Q.SHARP_EDGE_DEG = 0.0, 0.0           # everything bends too much now
        b = assess_mesh((V, F), lref=8.0, with_fields=False)
    finally:
        Q.NORMAL_P99_CAUTION, Q.SHARP_EDGE_DEG = old
    assert b.provenance["quality"]["advisory"] == "poor"
    for m in METRICS:
        assert b.validity[m].value == a.validity[m].value
    assert b.validity["I_D"].status.value == "MESH-SENSITIVE"
