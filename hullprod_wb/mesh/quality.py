"""Mesh-quality and representation provenance (paper section 4.2: topology, boundary
fraction, triangle quality, edge-length and associated-area distributions, valence,
connected components, watertightness, and the adjacent-face normal variation).

The normal variation, the angle between the normals of two triangles sharing an edge,
depends directly on resolution and tessellation; it is a diagnostic only and never
enters the signature.

Advisory ('good' | 'caution' | 'poor') on the reliability of mesh curvature, with reasons:

poor when any of
  - non-manifold edges are present,
  - the winding cannot be made consistent (non-orientable triangles),
  - more than 1 % of the triangles are slivers (shape quality q < 0.1),
  - the 1st percentile of the smallest angle is below 5 degrees,
  - more than 1 % of the interior edges bend by more than 30 degrees (sharp edges or a
    tessellation far too coarse for its curvature);
caution when any of
  - degenerate triangles were removed at loading,
  - more than 5 % of the triangles have q < 0.3,
  - the edge lengths span more than a factor 20 between the 1st and 99th percentiles,
  - more than 10 % of the interior vertices have a valence outside 4..8,
  - the 99th percentile of the normal variation exceeds 10 degrees (coarse for its curvature),
  - the mesh has more than one connected component, or duplicated triangles;
good otherwise. The advisory judges the tessellation only; the boundary fractions are
reported here, and the share of area without valid curvature is judged by the backend.
Shape quality q = 4 sqrt(3) A / (l0^2 + l1^2 + l2^2) is 1 for an equilateral triangle,
0.87 for a right isosceles one and tends to 0 for slivers.
"""
from concurrent.futures import ThreadPoolExecutor

import numpy as np

from ..core.threads import default_threads
from .curvature import check_arrays
from .face_geometry import coordinate_rows, edge_lengths, face_measures, normal_angles, unit_normals, \
    vertex_areas
from .topology import edge_table

#: Percentiles of every distribution summary.
PERCENTILES = (1, 5, 50, 95, 99)

# Advisory thresholds (see module docstring).
SLIVER_Q = 0.1
SLIVER_FRACTION_POOR = 0.01
MIN_ANGLE_P01_POOR = 5.0
SHARP_EDGE_DEG = 30.0
SHARP_FRACTION_POOR = 0.01
LOW_Q = 0.3
LOW_Q_FRACTION_CAUTION = 0.05
EDGE_SPREAD_CAUTION = 20.0
IRREGULAR_VALENCE_CAUTION = 0.10
NORMAL_P99_CAUTION = 10.0


def summary(x):
    """min, p01, p05, median, p95, p99, max and mean of x (None entries when x is empty).

    The percentiles (linear interpolation, np.percentile) come from one partition of a
    copy of the finite values."""
    x = np.asarray(x, dtype=float)
    x = x[np.isfinite(x)]
    keys = ("min", "p01", "p05", "median", "p95", "p99", "max", "mean")
    if x.size == 0:
        return dict.fromkeys(keys)
    lo, hi, mean = x.min(), x.max(), x.mean()
    p = np.percentile(x, PERCENTILES, overwrite_input=True)
    vals = (lo, *p, hi, mean)
    return {k: float(v) for k, v in zip(keys, vals)}


def summaries(arrays):
    """name -> summary(array) for a dict of arrays, on default_threads() threads."""
    names = list(arrays)
    threads = default_threads()
    if threads > 1 and len(names) > 1:
        with ThreadPoolExecutor(max_workers=threads) as pool:
            done = list(pool.map(lambda k: summary(arrays[k]), names))
    else:
        done = [summary(arrays[k]) for k in names]
    return dict(zip(names, done))


def triangle_measures(V, F):
    """Per-triangle area (m,), shape quality q (m,), smallest and largest angle in degrees (m,)."""
    fm = face_measures(V, F)
    return fm.area, fm.quality, fm.min_angle, fm.max_angle


def normal_variation(V, F, table=None):
    """Angle in degrees between the unit normals of the two triangles at every manifold
    interior edge: (p,) angles and (p, 2) face pairs. Diagnostic only."""
    if table is None:
        table = edge_table(F, len(V))
    return normal_angles(unit_normals(V, F), table.pairs), table.pairs


def _components(n, edges):
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components
    g = coo_matrix((np.ones(len(edges), dtype=np.int8), (edges[:, 0], edges[:, 1])), shape=(n, n))
    return int(connected_components(g, directed=False)[0])


def _parts(mesh):
    """(V, F, preparation record, EdgeTable, FaceMeasures, coordinate rows) of a
    PreparedMesh (its own table, measures and rows), trimesh.Trimesh or (V, F)."""
    if hasattr(mesh, "table") and hasattr(mesh, "measures"):   # loading.PreparedMesh
        return mesh.vertices, mesh.faces, mesh.info, mesh.table, mesh.measures, mesh.rows
    if isinstance(mesh, tuple):
        V, F = check_arrays(*mesh)
        prep = {}
    else:
        V, F = check_arrays(np.asarray(mesh.vertices), np.asarray(mesh.faces))
        meta = getattr(mesh, "metadata", None) or {}
        prep = meta.get("hullprod", {})
    rows = coordinate_rows(V)
    return V, F, prep, edge_table(F, len(V)), face_measures(V, F, rows), rows


def mesh_quality(mesh):
    """Quality and provenance summary of a triangle mesh (loading.PreparedMesh,
    trimesh.Trimesh or (V, F)).

    Returns a JSON-ready dict: counts, areas, topology, distributions (min/p01/p05/median/
    p95/p99/max/mean) and the advisory with its reasons (module docstring). A PreparedMesh
    prepared with its quality record gives that record.
    """
    if getattr(mesh, "quality", None) is not None:
        return mesh.quality
    V, F, prep, table, fm, rows = _parts(mesh)
    return finished_record(measured_record(V, F, table, fm, rows), prep, table)


def measured_record(V, F, table, fm, rows=None):
    """The part of the quality record measured on the triangles (V, F) with their EdgeTable
    and FaceMeasures (rows: V's coordinate_rows when at hand): everything but the connected
    components, what the preparation reports and the advisory (finished_record adds them)."""
    rows = coordinate_rows(V) if rows is None else rows
    n, m = len(V), len(F)
    ne = len(table.count)
    area, q, amin, amax = fm.area, fm.quality, fm.min_angle, fm.max_angle
    total = float(area.sum())
    vertex_area = vertex_areas(F, area, n)
    be = table.edges[table.count == 1]
    bnd, nmv = table.vertex_flags(n)
    n_nme = int(np.count_nonzero(table.count > 2))
    lengths = edge_lengths(V, table.edges, rows)
    valence = np.bincount(table.edges.ravel(), minlength=n)
    interior = ~bnd & ~nmv & (valence > 0)
    irregular = interior & ((valence < 4) | (valence > 8))
    nvar = normal_angles(unit_normals(V, F, rows), table.pairs)
    same = table.same_direction(F)
    interior_edges = int(len(nvar))
    sharp = int(np.count_nonzero(nvar > SHARP_EDGE_DEG))
    vhist = np.bincount(valence)
    dist = summaries({"triangle_quality": q, "min_angle_deg": amin, "max_angle_deg": amax,
                      "edge_length": lengths, "vertex_area": vertex_area, "normal_variation_deg": nvar})
    return {
        "counts": {"vertices": n, "faces": m, "edges": ne},
        "total_area": total,
        "boundary": {
            "edges": int(len(be)),
            "edge_fraction": len(be) / ne if ne else 0.0,
            "vertices": int(bnd.sum()),
            "vertex_fraction": float(bnd.mean()) if n else 0.0,
            "vertex_area_fraction": float(vertex_area[bnd].sum() / total) if total > 0 else 0.0,
        },
        "nonmanifold": {"edges": n_nme, "vertices": int(nmv.sum())},
        "inconsistent_winding_edges": int(np.count_nonzero(same)),
        "watertight": bool(len(be) == 0 and n_nme == 0),
        "triangle_quality": dist["triangle_quality"],
        "sliver_fraction": float(np.mean(q < SLIVER_Q)) if m else 0.0,
        "low_quality_fraction": float(np.mean(q < LOW_Q)) if m else 0.0,
        "min_angle_deg": dist["min_angle_deg"],
        "max_angle_deg": dist["max_angle_deg"],
        "edge_length": dist["edge_length"],
        "vertex_area": dist["vertex_area"],
        "valence": {
            "histogram": {int(k): int(c) for k, c in enumerate(vhist) if c},
            "min": int(valence.min()) if n else 0,
            "max": int(valence.max()) if n else 0,
            "mean": float(valence.mean()) if n else 0.0,
            "interior_irregular_fraction": float(irregular.sum() / max(1, interior.sum())),
        },
        "normal_variation_deg": dict(dist["normal_variation_deg"], interior_edges=interior_edges,
                                     above_30deg=sharp,
                                     note="diagnostic only, never part of the signature"),
    }


def finished_record(measured, prep, table):
    """The quality record: measured_record with the connected components (of the vertex
    graph of table's edges; 1 when the preparation found one piece, every vertex of a
    prepared mesh being used), the counts the preparation reports (prep) and the advisory."""
    n = measured["counts"]["vertices"]
    components = 1 if prep.get("pieces") == 1 else _components(n, table.edges)
    out = {}
    for key, value in measured.items():
        out[key] = value
        if key == "inconsistent_winding_edges":
            out["connected_components"] = components
        elif key == "watertight":
            out["degenerate_faces_removed"] = int(prep.get("degenerate_faces_removed", 0))
            out["duplicate_faces"] = int(prep.get("duplicate_faces", 0))
            out["non_orientable_faces"] = int(prep.get("non_orientable_faces", 0))
    out["advisory"], out["reasons"] = advisory(out)
    return out


def advisory(qd):
    """('good' | 'caution' | 'poor', [reasons]) from a mesh_quality dict (module docstring)."""
    poor, caution = [], []
    if qd["nonmanifold"]["edges"]:
        poor.append("%d non-manifold edges" % qd["nonmanifold"]["edges"])
    if qd["non_orientable_faces"]:
        poor.append("%d triangles cannot be oriented consistently" % qd["non_orientable_faces"])
    if qd["sliver_fraction"] > SLIVER_FRACTION_POOR:
        poor.append("%.1f %% of triangles are slivers (q < %g)" % (100 * qd["sliver_fraction"], SLIVER_Q))
    p01 = qd["min_angle_deg"]["p01"]
    if p01 is not None and p01 < MIN_ANGLE_P01_POOR:
        poor.append("1st percentile of the smallest angle is %.2f deg (< %g)" % (p01, MIN_ANGLE_P01_POOR))
    nv = qd["normal_variation_deg"]
    if nv["interior_edges"] and nv["above_30deg"] / nv["interior_edges"] > SHARP_FRACTION_POOR:
        poor.append("%.1f %% of interior edges bend by more than %g deg"
                    % (100.0 * nv["above_30deg"] / nv["interior_edges"], SHARP_EDGE_DEG))
    if qd["degenerate_faces_removed"]:
        caution.append("%d degenerate triangles removed" % qd["degenerate_faces_removed"])
    if qd["low_quality_fraction"] > LOW_Q_FRACTION_CAUTION:
        caution.append("%.1f %% of triangles have shape quality q < %g" % (100 * qd["low_quality_fraction"], LOW_Q))
    el = qd["edge_length"]
    if el["p01"] and el["p99"] / el["p01"] > EDGE_SPREAD_CAUTION:
        caution.append("edge lengths span a factor %.0f between 1st and 99th percentiles" % (el["p99"] / el["p01"]))
    irr = qd["valence"]["interior_irregular_fraction"]
    if irr > IRREGULAR_VALENCE_CAUTION:
        caution.append("%.1f %% of interior vertices have valence outside 4..8" % (100 * irr))
    if nv["p99"] is not None and nv["p99"] > NORMAL_P99_CAUTION:
        caution.append("99th percentile of the normal variation is %.1f deg (> %g)" % (nv["p99"], NORMAL_P99_CAUTION))
    if qd["connected_components"] > 1:
        caution.append("%d connected components" % qd["connected_components"])
    if qd["duplicate_faces"]:
        caution.append("%d duplicated triangles" % qd["duplicate_faces"])
    if poor:
        return "poor", poor + caution
    if caution:
        return "caution", caution
    return "good", []
