"""Curvature at a picked point of an analysed hull.

BRep: exact, by the BRep backend's probe_point on the face under the point. Mesh:
barycentric interpolation of the vertex K and H in the triangle containing the point
(labelled 'interpolated'); principal curvatures k1,2 = H +- sqrt(max(H^2 - K, 0)).
"""
import numpy as np

from ..core.constants import CLASS_NAMES
from ..core.errors import InputError
from ..core.thresholds import classify
from .analysis import analysis_fields

#: Class id -> name (-1 is invalid), eq:curvature_classes.
CLASS_LABELS = {-1: "invalid"}
CLASS_LABELS.update(dict(enumerate(CLASS_NAMES)))


def locate_triangle(points, triangles, p):
    """Triangle holding point p and its barycentric coordinates.

    points: (n, 3) float; triangles: (m, 3) int; p: (3,). Projects p on every triangle's
    plane; among triangles containing the projection (all coordinates >= -1e-6) the one
    nearest in plane distance wins, otherwise the triangle with the nearest centroid.
    Returns (index, (3,) barycentric, distance).
    """
    P = np.asarray(points, float)
    T = np.asarray(triangles, np.int64)
    p = np.asarray(p, float).reshape(3)
    a, b, c = P[T[:, 0]], P[T[:, 1]], P[T[:, 2]]
    e0, e1, d = b - a, c - a, p - a
    d00, d01, d11 = (e0 * e0).sum(1), (e0 * e1).sum(1), (e1 * e1).sum(1)
    d20, d21 = (d * e0).sum(1), (d * e1).sum(1)
    den = d00 * d11 - d01 * d01
    n = np.cross(e0, e1)
    area2 = np.linalg.norm(n, axis=1)
    # a degenerate (zero-area) triangle has no barycentric coordinates: it holds no point
    proper = (den > 0) & (area2 > 0)
    safe_den = np.where(proper, den, 1.0)
    v = np.where(proper, (d11 * d20 - d01 * d21) / safe_den, np.nan)
    w = np.where(proper, (d00 * d21 - d01 * d20) / safe_den, np.nan)
    u = 1.0 - v - w
    bary = np.column_stack([u, v, w])
    plane = np.where(proper, np.abs((d * n).sum(1)) / np.where(proper, area2, 1.0), np.inf)
    inside = proper & np.all(np.nan_to_num(bary, nan=-1.0) >= -1e-6, axis=1)
    if inside.any():
        idx = int(np.flatnonzero(inside)[np.argmin(plane[inside])])
        return idx, bary[idx], float(plane[idx])
    cen = (a + b + c) / 3.0
    idx = int(np.argmin(((cen - p) ** 2).sum(1)))
    bb = np.clip(np.nan_to_num(bary[idx]), 0.0, None)
    bb = bb / bb.sum() if bb.sum() > 0 else np.full(3, 1.0 / 3.0)
    return idx, bb, float(np.linalg.norm(bb @ P[T[idx]] - p))


def interpolate_fields(fields, p):
    """Barycentric interpolation of the mesh fields at p: dict(K, H, k1, k2, q_D, class_id, ...)."""
    tri, bary, dist = locate_triangle(fields.points, fields.triangles, p)
    ids = np.asarray(fields.triangles[tri], np.int64)
    ok = bool(np.all(np.asarray(fields.valid)[ids]))

    def at(values):
        return float(bary @ np.asarray(values)[ids])

    if not ok:  # a corner without valid curvature (boundary, non-manifold): no value at all
        K = H = k1 = k2 = float("nan")
        how = "display triangle %d of the mesh fields has a corner without valid curvature " \
              "(boundary or non-manifold)" % tri
    else:
        K, H = at(fields.K), at(fields.H)
        if "k1" in fields.extra and "k2" in fields.extra:
            k1, k2 = at(fields.extra["k1"]), at(fields.extra["k2"])
        else:
            r = np.sqrt(max(H * H - K, 0.0))
            k1, k2 = H + r, H - r
        how = "interpolated: barycentric in display triangle %d of the mesh fields" % tri
    cls = int(classify(np.array([K]), np.array([H]), fields.tau_H, fields.tau_K)[0])
    return {"K": K, "H": H, "k1": k1, "k2": k2, "q_D": abs(K) * fields.lref ** 2,  # NaN where K is
            "class_id": cls, "triangle": tri, "barycentric": [float(x) for x in bary], "distance": dist,
            "exact": False, "method": how}


def probe_analysis(obj, point):
    """Curvature of analysis obj at point (3,) in model coordinates.

    Returns dict(K, H, k1, k2, q_D, class_id, class_name, exact, method, point, face?).
    """
    fields = analysis_fields(obj)
    if fields is None:
        raise InputError("the analysis %s has no stored fields to probe: recompute it" % obj.Label)
    p = np.asarray([point[0], point[1], point[2]], float)
    if obj.Representation == "brep":
        tri, bary, _ = locate_triangle(fields.points, fields.triangles, p)
        face_ids = np.asarray(fields.extra.get("face_id", ()))
        if not len(face_ids):
            raise InputError("the stored BRep fields of %s carry no face numbers" % obj.Label)
        face = int(face_ids[fields.triangles[tri][int(np.argmax(bary))]])
        from ..brep.backend import probe_point
        out = dict(probe_point(obj.Source.Shape, face, tuple(p), obj.LrefUsed, obj.Hf, obj.Kf))
        out.update(face=face, exact=bool(out.get("exact", True)),
                   method="exact: BRep face %d at the surface point under the cursor" % face)
    else:
        out = interpolate_fields(fields, p)
    out["point"] = [float(x) for x in p]
    out["class_name"] = CLASS_LABELS.get(int(out["class_id"]), "?")
    return out
