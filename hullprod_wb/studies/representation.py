"""Representation comparison: native BRep against a triangulated realization of the same
hull (paper section 6.4, Table tab:publicsignatures).

The BRep is assessed natively; the mesh (a user mesh, or by default the finest level of the
tessellation ladder: linear deflection 0.000875 L_ref, angular 0.2 rad) by the mesh
backend with the same L_ref and thresholds. Reported side by side:

    Delta I_D [%] = 100 (I_D(mesh) - I_D(BRep)) / I_D(BRep)

(likewise I_D+, I_D-), the class fractions of both, their differences
a_C(mesh) - a_C(BRep) (the class redistribution) and d1 (eq:class_l1). These are
representation differences, not curvature-estimator errors (compare the same-face study).
"""
from ..core.constants import CLASS_NAMES, DEFAULT_HF, DEFAULT_KF
from ..core.progress import null_progress, sub_progress
from ..core.writers import json_safe
from .refinement import (ANGULAR_DEFLECTIONS, LINEAR_DEFLECTIONS, _signature_row, class_l1,
                         mesh_counts, mesh_quality_of, relative_change, tessellate)


def percent(x):
    return None if x is None else 100.0 * x


def representation_study(source, mesh=None, lref=None, mesh_lref=None, h_f=DEFAULT_HF, k_f=DEFAULT_KF,
                         faces=None, linear=LINEAR_DEFLECTIONS[-1], angular=ANGULAR_DEFLECTIONS[-1],
                         brep_options=None, progress=None, brep_assessment=None):
    """Native BRep versus a triangulated realization (see module docstring).

    source: BRep path, Part.Shape or FreeCAD object. mesh: user mesh (path, (V, F) or mesh
    object) or None for the tessellation at linear * L_ref, angular rad. lref: L_ref in the
    BRep's units (None: the BRep assessment's automatic value); mesh_lref: L_ref in the
    mesh's units when they differ (default: lref). brep_options: quadrature options for the
    BRep backend. brep_assessment: an existing BRep Assessment to reuse. Returns a JSON-safe
    dict: study, input, rows [BRep, mesh], delta (percent), class_redistribution, d1.
    """
    from ..api import assess
    from ..brep.reading.loading import load_brep
    progress = progress or null_progress
    progress(0.0, "native BRep assessment")
    b = brep_assessment
    if b is None:
        b = assess(source, lref=lref, h_f=h_f, k_f=k_f, backend="brep", faces=faces, with_fields=False,
                   progress=sub_progress(progress, 0.0, 0.6, "native BRep: "), **(brep_options or {}))
    L = b.reference_length.value
    progress(0.6, "triangulated realization")
    if mesh is None:
        brep = load_brep(source, faces)
        shape = brep.shape
        if faces is not None:
            import Part
            shape = Part.makeCompound([f for _, f in brep.faces])
        mesh = tessellate(shape, linear * L, angular)
        mesh_desc = {"kind": "tessellation", "linear_deflection_over_lref": float(linear),
                     "angular_deflection_rad": float(angular), "n_vertices": len(mesh[0]),
                     "n_triangles": len(mesh[1])}
    else:
        mesh_desc = {"kind": "user mesh", "path": mesh if isinstance(mesh, str) else None}
    progress(0.7, "triangle mesh")
    m = assess(mesh, lref=mesh_lref or L, h_f=h_f, k_f=k_f, backend="mesh", with_fields=False,
               progress=sub_progress(progress, 0.7, 1.0, "triangle mesh: "))
    rb = dict(_signature_row(b), representation="native BRep")
    rm = dict(_signature_row(m), representation="triangle mesh", quality=mesh_quality_of(m))
    if "n_triangles" not in mesh_desc:
        mesh_desc["n_vertices"], mesh_desc["n_triangles"] = mesh_counts(m)
    delta = {q: percent(relative_change(rm[q], rb[q])) for q in ("I_D", "I_D_plus", "I_D_minus")}
    redistribution = {}
    for n in CLASS_NAMES:
        a, c = rb["a_C"].get(n), rm["a_C"].get(n)
        redistribution[n] = None if a is None or c is None else c - a
    progress(1.0, "representation study done")
    doc = {"study": "representation", "input": b.input, "mesh": mesh_desc, "lref": L,
           "mesh_lref": mesh_lref or L, "settings": {"h_f": h_f, "k_f": k_f},
           "rows": [rb, rm], "delta_percent": delta, "class_redistribution": redistribution,
           "d1": class_l1(rb["a_C"], rm["a_C"]),
           "double_curved": {"brep": _double(rb), "mesh": _double(rm)}}
    return json_safe(doc)


def _double(row):
    e, s = row["a_C"].get("elliptic"), row["a_C"].get("saddle")
    return None if e is None or s is None else e + s
