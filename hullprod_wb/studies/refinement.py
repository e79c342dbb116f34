"""Mesh-resolution sensitivity (paper section 5.2 and 6.4, eq:class_l1).

A ladder of triangle meshes of one hull, coarse to fine, either given by the user or made
from a BRep with OpenCascade's tessellation (MeshPart.meshFromShape, absolute deflections)
at linear deflections (0.0035, 0.00175, 0.000875) L_ref and angular deflections
(0.3, 0.25, 0.2) rad; the finest of these is the paper's frozen fine-STL setting. Every
level is assessed by the mesh backend with the same L_ref and thresholds; each level's
signature is compared with the finest level's (the reference):

    relative change of X = (X_level - X_finest) / |X_finest|, X in {I_D, I_D+, I_D-}
    d1 = || a_C(level) - a_C(finest) ||_1                              (eq:class_l1)

This is a resolution-sensitivity study of mesh realizations, not a convergence study
towards the native BRep value (paper section 6.4).
"""
import os

import numpy as np

from ..core.constants import CLASS_NAMES, DEFAULT_HF, DEFAULT_KF
from ..core.errors import InputError
from ..core.progress import null_progress, sub_progress
from ..core.writers import json_safe

#: Default linear deflections of the tessellation ladder, as fractions of L_ref.
LINEAR_DEFLECTIONS = (0.0035, 0.00175, 0.000875)
#: Default angular deflections of the ladder (rad).
ANGULAR_DEFLECTIONS = (0.3, 0.25, 0.2)
#: Names of three-level ladders.
LEVEL_NAMES = ("coarse", "medium", "fine")


def class_l1(a, b):
    """d1(a, b) = sum |a_c - b_c| over the four class fractions (eq:class_l1); None if any is None."""
    a = _class_vector(a)
    b = _class_vector(b)
    if a is None or b is None:
        return None
    return float(np.abs(a - b).sum())


def _class_vector(a):
    if isinstance(a, dict):
        a = [a.get(n) for n in CLASS_NAMES]
    if a is None or any(x is None for x in a):
        return None
    return np.asarray(a, dtype=float)


def relative_change(x, ref):
    """(x - ref) / |ref|, None when either is None or ref is 0."""
    if x is None or ref is None or ref == 0:
        return None
    return float((x - ref) / abs(ref))


def tessellate(shape, linear, angular):
    """(vertices (n, 3) float, triangles (m, 3) int) of OpenCascade's tessellation of shape.

    linear: absolute linear deflection (shape units); angular: angular deflection (rad).
    """
    from ..freecad_env import import_freecad
    import_freecad()
    import MeshPart
    mesh = MeshPart.meshFromShape(Shape=shape, LinearDeflection=float(linear),
                                  AngularDeflection=float(angular), Relative=False)
    points, facets = mesh.Topology
    if not facets:
        raise InputError("the tessellation of the shape is empty (linear deflection %g, angular %g)"
                         % (linear, angular))
    V = np.array([(p.x, p.y, p.z) for p in points], dtype=float)
    return V, np.asarray(facets, dtype=np.int64).reshape(-1, 3)


def brep_lref(brep, lref=None):
    """The reference length of a BRep: explicit, or the automatic principal-axis span of a
    coarse tessellation (the same rule the backends use)."""
    from ..core.reference_length import resolve_reference_length
    shape = brep.shape
    V, F = tessellate(shape, 1e-3 * max(shape.BoundBox.DiagonalLength, 1e-300), 0.5)
    return resolve_reference_length(V, F, explicit=lref)


def tessellation_ladder(source, lref=None, linear=LINEAR_DEFLECTIONS, angular=ANGULAR_DEFLECTIONS,
                        faces=None):
    """Meshes of a BRep at the ladder's deflections (linear given as fractions of L_ref).

    Returns (levels, brep input, ReferenceLength): levels is a list of dicts with name,
    linear_deflection (fraction of L_ref), angular_deflection, mesh (V, F).
    """
    from ..brep.reading.loading import load_brep
    linear, angular = list(linear), list(angular)
    if len(linear) != len(angular) or len(linear) < 2:
        raise InputError("the ladder needs as many linear as angular deflections, at least two "
                         "levels; got %d and %d" % (len(linear), len(angular)))
    if min(linear) <= 0 or min(angular) <= 0:
        raise InputError("deflections must be > 0")
    brep = load_brep(source, faces)
    shape = brep.shape
    if faces is not None:
        import Part
        shape = Part.makeCompound([f for _, f in brep.faces])
    rl = brep_lref(brep, lref)
    names = LEVEL_NAMES if len(linear) == 3 else ["level %d" % (k + 1) for k in range(len(linear))]
    levels = []
    for name, lin, ang in zip(names, linear, angular):
        V, F = tessellate(shape, lin * rl.value, ang)
        levels.append({"name": name, "linear_deflection": float(lin), "angular_deflection": float(ang),
                       "mesh": (V, F)})
    return levels, brep, rl


def _signature_row(assessment):
    sig = assessment.signature
    row = {"I_D": sig["I_D"], "I_D_plus": sig["I_D_plus"], "I_D_minus": sig["I_D_minus"],
           "a_C": dict(sig["a_C"]),
           "status": {m: v.status.value for m, v in assessment.validity.items()},
           "represented_area": assessment.integrals.represented_area,
           "valid_area": assessment.integrals.valid_area}
    A = assessment.integrals.represented_area
    row["valid_area_fraction"] = assessment.integrals.valid_area / A if A > 0 else None
    return row


def mesh_quality_of(assessment):
    """The mesh-quality record of a mesh assessment's provenance (or None)."""
    prov = assessment.provenance or {}
    for key in ("quality", "mesh_quality"):
        if key in prov:
            return prov[key]
    mesh = prov.get("mesh") or {}
    return mesh.get("quality")


def mesh_counts(assessment):
    """(vertices, triangles) of a mesh assessment, from its quality record (or None, None)."""
    c = (mesh_quality_of(assessment) or {}).get("counts") or {}
    return c.get("vertices"), c.get("faces")


def assess_mesh_level(mesh, lref, h_f, k_f, progress=None):
    """Mesh-backend assessment of one ladder level (path, (V, F) or mesh object)."""
    from ..api import assess
    return assess(mesh, lref=lref, h_f=h_f, k_f=k_f, backend="mesh", with_fields=False, progress=progress)


def compare_levels(rows):
    """Fill each row's changes against the last (finest) row, in place; returns rows."""
    ref = rows[-1]
    for r in rows:
        r["relative_change"] = {q: relative_change(r[q], ref[q]) for q in ("I_D", "I_D_plus", "I_D_minus")}
        r["d1"] = class_l1(r["a_C"], ref["a_C"])
    return rows


def refinement_study(source=None, meshes=None, lref=None, h_f=DEFAULT_HF, k_f=DEFAULT_KF,
                     linear=LINEAR_DEFLECTIONS, angular=ANGULAR_DEFLECTIONS, faces=None, names=None,
                     progress=None):
    """Mesh-resolution sensitivity of a ladder of meshes (see module docstring).

    source: a BRep (path, Part.Shape or FreeCAD object) tessellated into the ladder; or
    meshes: a list of meshes (paths, (V, F) or mesh objects) ordered coarse to fine, the last
    the reference. lref: L_ref in the input's units (BRep: explicit or automatic from the
    shape; meshes: explicit or the automatic value of the finest mesh, used for all levels).
    Returns a JSON-safe dict: study, input, settings, levels (rows with counts, signature,
    statuses, quality, relative_change vs finest, d1 vs finest), successive (changes between
    consecutive levels).
    """
    progress = progress or null_progress
    if (source is None) == (meshes is None):
        raise InputError("give either a BRep source to tessellate or a list of meshes, not both")
    settings = {"h_f": h_f, "k_f": k_f, "reference": "finest level (last)"}
    if source is not None:
        progress(0.0, "tessellating the ladder")
        ladder, brep, rl = tessellation_ladder(source, lref, linear, angular, faces)
        inp = dict(brep.info)
        settings.update({"ladder": "OpenCascade tessellation (MeshPart.meshFromShape, Relative=False)",
                         "linear_deflection_over_lref": list(linear), "angular_deflection_rad": list(angular)})
        lref_value = rl.value
        ref_len = rl.to_dict()
    else:
        meshes = list(meshes)
        if len(meshes) < 2:
            raise InputError("a refinement ladder needs at least two meshes, got %d" % len(meshes))
        names = list(names) if names else [_mesh_name(m, k) for k, m in enumerate(meshes)]
        ladder = [{"name": n, "mesh": m} for n, m in zip(names, meshes)]
        inp = {"meshes": [m if isinstance(m, str) else n for m, n in zip(meshes, names)]}
        lref_value = lref
        ref_len = None
        settings["ladder"] = "user meshes, coarse to fine"
    rows = []
    order = list(range(len(ladder)))
    if lref_value is None:  # user meshes without L_ref: the finest mesh's automatic value for all
        progress(0.0, "reference length from the finest mesh")
        fine = assess_mesh_level(ladder[-1]["mesh"], None, h_f, k_f)
        lref_value = fine.reference_length.value
        ref_len = fine.reference_length.to_dict()
    for k in order:
        lv = ladder[k]
        progress(k / len(ladder), "assessing %s" % lv["name"])
        a = assess_mesh_level(lv["mesh"], lref_value, h_f, k_f,
                              sub_progress(progress, k / len(ladder), (k + 1) / len(ladder), lv["name"] + ": "))
        row = {"name": lv["name"]}
        for key in ("linear_deflection", "angular_deflection"):
            if key in lv:
                row[key] = lv[key]
        if isinstance(lv["mesh"], tuple):
            row["n_vertices"], row["n_triangles"] = int(len(lv["mesh"][0])), int(len(lv["mesh"][1]))
        else:
            row["n_vertices"], row["n_triangles"] = mesh_counts(a)
        row.update(_signature_row(a))
        row["quality"] = mesh_quality_of(a)
        rows.append(row)
    compare_levels(rows)
    successive = []
    for lo, hi in zip(rows[:-1], rows[1:]):
        successive.append({"from": lo["name"], "to": hi["name"],
                           "relative_change_I_D": relative_change(lo["I_D"], hi["I_D"]),
                           "d1": class_l1(lo["a_C"], hi["a_C"])})
    progress(1.0, "refinement study done")
    doc = {"study": "refinement", "input": inp, "reference_length": ref_len or {"value": lref_value},
           "lref": lref_value, "settings": settings, "levels": rows, "successive": successive}
    return json_safe(doc)


def _mesh_name(m, k):
    if isinstance(m, (str, os.PathLike)):
        return os.path.basename(os.fspath(m))
    return "mesh %d" % (k + 1)
