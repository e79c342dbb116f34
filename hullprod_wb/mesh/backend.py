"""Triangle-mesh realization of the signature (paper section 4.2, eq:mesh_ID; validity
section 4.3).

Curvature per vertex by the Rusinkiewicz tensor method (eq:mesh_hk), barycentric vertex
areas A_i (eq:vertex_area), and area-weighted sums over the valid domain V_K: interior
vertices (not on a boundary or non-manifold edge) with finite K and H. The represented
area is the sum of all triangle areas. No smoothing, clipping, remeshing or repair is
applied beyond the preparation of :mod:`.loading`.

Validity of each of the seven metrics (rule):

- NOT EVALUATED, value None: the valid domain has no area (no interior vertex with a
  finite curvature), so the metric's denominator is zero;
- MESH-SENSITIVE: the value is finite but the mesh-quality advisory is 'poor'
  (:mod:`.quality`), or more than EXCLUDED_AREA_SENSITIVE (5 %) of the represented area
  is outside the valid domain (boundary, non-manifold or non-finite vertices). An area
  average over a domain that misses a twentieth of the surface can differ from the
  whole-surface value by an amount of that order, and a poor tessellation makes the
  reconstructed curvature depend on connectivity and quality;
- VALID otherwise.

Every record carries as evidence the excluded areas, the valid-area fraction, the quality
advisory with its reasons, and the value recomputed on the strict interior (the valid
domain less the vertices next to a boundary), which shows how much the value depends on
the boundary treatment.
"""
import os
import time
from concurrent.futures import ThreadPoolExecutor

import numpy as np

from ..core.constants import CLASS_METRICS, DEFAULT_HF, DEFAULT_KF, METRICS
from ..core.errors import InputError
from ..core.fields import DistributedFields
from ..core.inputs import checked_path, start_sha256
from ..core.integrals import integrals_from_samples
from ..core.progress import null_progress
from ..core.reference_length import resolve_reference_length
from ..core.result import Assessment
from ..core.signature import signature_values
from ..core.thresholds import Thresholds, check_positive
from ..core.validity import MetricValidity, Status
from .curvature import vertex_curvature
from .loading import file_record, load_prepared, prepared_from_arrays, \
    prepared_from_freecad, prepared_from_trimesh
from .memory import check_memory

#: Share of the represented area outside the valid domain above which values are MESH-SENSITIVE.
EXCLUDED_AREA_SENSITIVE = 0.05

CURVATURE_METHOD = ("Rusinkiewicz (2004) per-vertex curvature tensor: Max (1999) vertex normals, "
                    "exact least-squares face tensors, rotation to vertex frames, mixed Voronoi "
                    "corner-area averaging (Meyer et al. 2003)")


def open_mesh(source, progress=None):
    """(loading.PreparedMesh, input dict) from a path, trimesh, (vertices, faces) or FreeCAD
    mesh. progress(fraction of the loading, message)."""
    if isinstance(source, (str, os.PathLike)):
        path, fmt, _ = checked_path(source, "mesh")
        check_memory(path, fmt)
        start_sha256(path)        # digested beside the reading
        mesh = load_prepared(path, progress, with_quality=True)
        info = {"path": path, "format": fmt, "representation": "mesh"}
        info.update(file_record(path))
        return mesh, info
    if type(source).__module__.startswith("trimesh"):
        if not hasattr(source, "faces"):
            raise InputError("a trimesh %s is not a triangle mesh" % type(source).__name__)
        return prepared_from_trimesh(source, with_quality=True), {
            "path": None, "sha256": None, "format": "trimesh", "representation": "mesh"}
    if isinstance(source, (tuple, list)) and len(source) == 2:
        return prepared_from_arrays(*source, with_quality=True), {
            "path": None, "sha256": None, "format": "arrays", "representation": "mesh"}
    if hasattr(source, "Topology") or hasattr(source, "Mesh"):  # Mesh.Mesh or a Mesh::Feature
        mesh = prepared_from_freecad(source, with_quality=True)
        return mesh, {"path": None, "sha256": None, "format": "FreeCAD mesh", "representation": "mesh",
                      "name": getattr(source, "Label", None)}
    raise InputError("cannot assess %s as a triangle mesh: give a .stl/.obj/.ply path, a trimesh, "
                     "(vertices, faces) arrays or a FreeCAD mesh" % type(source).__name__)


def strict_interior(F, boundary, valid):
    """valid less every vertex sharing a triangle with a boundary vertex, (n,) bool."""
    near = np.zeros(len(valid), dtype=bool)
    touches = boundary[F[:, 0]] | boundary[F[:, 1]] | boundary[F[:, 2]]
    near[F[touches].ravel()] = True
    return valid & ~near


def validity_records(values, integrals, strict_values, quality, excluded):
    """The seven MetricValidity records by the rule of the module docstring."""
    A = integrals.represented_area
    A_K = integrals.valid_area
    frac_valid = A_K / A if A > 0 else 0.0
    base = {
        "valid_area_fraction": frac_valid,
        "excluded_area": A - A_K,
        "excluded_area_fraction": 1.0 - frac_valid,
        "excluded": excluded,
        "quality_advisory": quality["advisory"],
        "quality_reasons": list(quality["reasons"]),
    }
    reasons = []
    if quality["advisory"] == "poor":
        reasons.append("mesh quality is poor (%s)" % "; ".join(quality["reasons"]))
    if 1.0 - frac_valid > EXCLUDED_AREA_SENSITIVE:
        reasons.append("%.1f %% of the area has no valid curvature (boundary, non-manifold or "
                       "non-finite vertices; limit %g %%)" % (100 * (1 - frac_valid), 100 * EXCLUDED_AREA_SENSITIVE))
    records = {}
    for m in METRICS:
        ev = dict(base)
        ev["strict_interior_value"] = strict_values[m]
        sv, v = strict_values[m], values[m]
        if np.isfinite(sv) and np.isfinite(v):
            ev["strict_interior_change"] = sv - v
        area = integrals.classified_area if m in CLASS_METRICS else A_K
        if not (area > 0) or not np.isfinite(v):
            rec = MetricValidity(Status.NOT_EVALUATED, None, "no interior vertex with finite curvature",
                                 "no_valid_vertex", A, area, ev)
        elif reasons:
            code = "mesh_quality_poor" if quality["advisory"] == "poor" else "mesh_large_excluded_area"
            rec = MetricValidity(Status.MESH_SENSITIVE, v, "; ".join(reasons), code, A, area, ev)
        else:
            rec = MetricValidity(Status.VALID, v, "finite mesh value on %.1f %% of the area, quality %s"
                                 % (100 * frac_valid, quality["advisory"]), "mesh_valid", A, area, ev)
        records[m] = rec
    return records


def assess_mesh(mesh_or_path, lref=None, h_f=DEFAULT_HF, k_f=DEFAULT_KF, input_info=None,
                with_fields=True, progress=None):
    """Signature of a triangle mesh (module docstring). Returns an Assessment.

    mesh_or_path: .stl/.obj/.ply path, trimesh.Trimesh, (vertices, faces) or FreeCAD mesh;
    lref: reference length in the mesh's units (None: automatic); h_f, k_f: class
    tolerances; input_info: extra entries for the input record; progress(fraction, message).
    """
    progress = progress or null_progress
    timings = {}
    t0 = time.perf_counter()
    progress(0.0, "reading mesh")
    mesh, info = open_mesh(mesh_or_path, lambda f, msg: progress(0.2 * f, msg))
    if input_info:
        info.update(input_info)
    prep = dict(mesh.info)
    V, F = mesh.vertices, mesh.faces
    t1 = time.perf_counter()
    timings["load_s"] = t1 - t0

    quality = mesh.quality          # measured during the loading, beside the orientation
    timings["quality_s"] = mesh.quality_seconds
    flags = mesh.table.vertex_flags(len(V))
    face_area = mesh.measures.area  # for the reference length
    rows = mesh.rows                # the coordinate rows of the block passes
    del mesh              # the edge table and the other triangle measures: not needed any more

    progress(0.4, "curvature of %d vertices" % len(V))
    curv = vertex_curvature(V, F, flags=flags, rows=rows)
    del rows
    t3 = time.perf_counter()
    timings["curvature_s"] = t3 - t1

    progress(0.8, "signature")
    A = curv.vertex_area
    with ThreadPoolExecutor(max_workers=1) as pool:
        # the automatic L_ref: needed first unless one is given, else made beside the integrals
        reference = pool.submit(resolve_reference_length, V, F, A, explicit=lref, triangle_area=face_area)
        value = reference.result().value if lref is None else check_positive("reference length L_ref", lref)
        th = Thresholds(value, h_f, k_f)
        finite = np.isfinite(curv.K) & np.isfinite(curv.H)
        valid = ~curv.boundary & ~curv.nonmanifold & finite
        integrals = integrals_from_samples(curv.K, curv.H, A, valid, th.tau_H, th.tau_K,
                                           represented_weights=A)
        values = signature_values(integrals, value)
        strict = strict_interior(F, curv.boundary, valid)
        strict_values = signature_values(
            integrals_from_samples(curv.K, curv.H, A, strict, th.tau_H, th.tau_K), value)
        rl = reference.result()
    excluded = {
        "boundary_vertices": int(np.count_nonzero(curv.boundary)),
        "boundary_vertex_area": float(A[curv.boundary].sum()),
        "nonmanifold_vertices": int(np.count_nonzero(curv.nonmanifold & ~curv.boundary)),
        "nonmanifold_vertex_area": float(A[curv.nonmanifold & ~curv.boundary].sum()),
        "nonfinite_vertices": int(np.count_nonzero(~finite & ~curv.boundary & ~curv.nonmanifold)),
        "nonfinite_vertex_area": float(A[~finite & ~curv.boundary & ~curv.nonmanifold].sum()),
    }
    validity = validity_records(values, integrals, strict_values, quality, excluded)
    fields = None
    if with_fields:
        fields = DistributedFields(points=V, triangles=F, K=curv.K, H=curv.H, valid=valid, lref=rl.value,
                                   tau_H=th.tau_H, tau_K=th.tau_K, weights=A, kind="mesh-vertex",
                                   extra={"k1": curv.k1, "k2": curv.k2})
    t4 = time.perf_counter()
    timings["signature_s"] = t4 - t3
    timings["total_s"] = t4 - t0

    warnings = []
    if rl.warning:
        warnings.append(rl.warning)
    if quality["advisory"] == "poor":
        warnings.append("mesh quality is poor: " + "; ".join(quality["reasons"]))
    if prep.get("degenerate_faces_removed"):
        warnings.append("%d degenerate triangles were removed" % prep["degenerate_faces_removed"])
    if prep.get("nonmanifold_edges"):
        warnings.append("%d non-manifold edges; their vertices are excluded from the valid domain"
                        % prep["nonmanifold_edges"])
    provenance = {
        "backend": "mesh",
        "curvature_method": CURVATURE_METHOD,
        "vertex_area": "barycentric: A_i = sum of incident triangle areas / 3",
        "valid_domain": "interior vertices (not on a boundary or non-manifold edge) with finite K and H",
        "mesh_counts": {"vertices": int(len(V)), "faces": int(len(F))},
        "preparation": prep,
        "orientation": {k: prep.get(k) for k in ("orientation_changed", "winding_flipped_faces",
                                                 "inverted_closed_pieces", "non_orientable_faces")},
        "excluded": excluded,
        "quality": quality,
        "validity_rule": {"excluded_area_sensitive": EXCLUDED_AREA_SENSITIVE,
                          "quality_poor_is_sensitive": True},
    }
    options = {"lref": lref, "h_f": h_f, "k_f": k_f, "with_fields": with_fields}
    progress(1.0, "done")
    return Assessment(input=info, reference_length=rl, thresholds=th, integrals=integrals,
                      validity=validity, fields=fields, provenance=provenance, options=options,
                      timings=timings, warnings=warnings)
