"""Self-test of an installed workbench: checks of closed forms and of the whole path a user
takes (file, reading process, assessment, document object, export), each a plain function
that raises AssertionError saying what differs.

FreeCAD's test runner runs them through ``TestHullProd`` (``freecadcmd -t TestHullProd``, the
Test workbench); the pytest suite runs the same module. Closed forms: paper section 5.1 and
Table tab:brepanalytic. Headless: no FreeCADGui, no Qt.
"""
import hashlib
import json
import math
import os

import numpy as np

from .core.errors import InputError

#: I_D relative error and class-fraction error the BRep controls are held to (paper Table
#: tab:brepanalytic accuracy goals).
RTOL_ID = 1e-9
ATOL_CLASS = 1e-6
#: Rounding-level tolerance for what the mesh method reproduces exactly (icosphere).
MESH_EXACT = 1e-10
#: The published half-Wigley reference has 9 significant digits.
WIGLEY_RTOL = 2e-9


def close(actual, expected, what, rel=0.0, abs_=0.0):
    """Raise AssertionError unless |actual - expected| <= max(rel |expected|, abs_)."""
    if actual is None or not (abs(actual - expected) <= max(rel * abs(expected), abs_)):
        raise AssertionError("%s is %r, expected %r (rel %g, abs %g)" % (what, actual, expected, rel, abs_))


def check(condition, message):
    """Raise AssertionError(message) unless condition."""
    if not condition:
        raise AssertionError(message)


def fractions(result):
    """(flat, single, elliptic, saddle) area fractions a_C of a result (paper eq:classfrac)."""
    a = result.signature["a_C"]
    return np.array([a["flat"], a["single"], a["elliptic"], a["saddle"]])


def statuses(result):
    """{metric: status label} of a result."""
    return {m: v.status.value for m, v in result.validity.items()}


def check_fractions(result, expected, atol=ATOL_CLASS):
    got = fractions(result)
    check(np.all(np.abs(got - np.asarray(expected)) <= atol),
          "class fractions %s, expected %s within %g" % (got.tolist(), list(expected), atol))


# -- BRep closed forms ---------------------------------------------------------------------------
def check_plane():
    """A 2 x 3 plane: K = H = 0 everywhere, all flat, every metric VALID, area 6."""
    from . import assess
    from .examples.analytic_shapes import plane_face
    r = assess(plane_face(), lref=3.0)
    for m in ("I_D", "I_D_plus", "I_D_minus"):
        check(r.signature[m] == 0.0, "%s of a plane is %r, not 0" % (m, r.signature[m]))
    check_fractions(r, [1, 0, 0, 0])
    check(set(statuses(r).values()) == {"VALID"}, "plane statuses %s" % statuses(r))
    close(r.integrals.represented_area, 6.0, "plane area", rel=1e-12)


def check_unit_sphere():
    """Unit sphere, L_ref = 2: K = 1, I_D = I_D+ = 4, all elliptic; the poles are detected as
    a parameterisation degeneracy and the value stays established."""
    from . import assess
    from .examples.analytic_shapes import unit_sphere
    r = assess(unit_sphere(), lref=2.0)
    close(r.signature["I_D"], 4.0, "sphere I_D", rel=RTOL_ID)
    close(r.signature["I_D_plus"], 4.0, "sphere I_D+", rel=RTOL_ID)
    check(r.signature["I_D_minus"] == 0.0, "sphere I_D- is %r" % r.signature["I_D_minus"])
    check_fractions(r, [0, 0, 1, 0])
    close(r.integrals.represented_area, 4 * math.pi, "sphere area", rel=1e-10)
    check(r.validity["I_D"].established, "sphere I_D not established: %s" % r.validity["I_D"].reason)
    check(r.provenance["degenerate_points"], "the sphere's poles were not reported")


def check_torus():
    """Torus R = 3, r = 1, L_ref = 8: I_D = 128/(3 pi), I_D+ = I_D- = I_D/2, the closed-form
    class fractions, every metric VALID."""
    from . import assess
    from .examples.analytic_shapes import TORUS_I_D, TORUS_LREF, torus_fractions, torus_shape
    r = assess(torus_shape(), lref=TORUS_LREF)
    close(r.signature["I_D"], TORUS_I_D, "torus I_D", rel=RTOL_ID)
    close(r.signature["I_D_plus"], TORUS_I_D / 2, "torus I_D+", rel=RTOL_ID)
    close(r.signature["I_D_minus"], TORUS_I_D / 2, "torus I_D-", rel=RTOL_ID)
    check_fractions(r, torus_fractions())
    check(set(statuses(r).values()) == {"VALID"}, "torus statuses %s" % statuses(r))


def check_saddle():
    """Saddle z = (x^2 - y^2)/4 on [-1, 1]^2, L_ref = 2, at rtol 1e-6: the closed form to 1e-9,
    all of it I_D-, all saddle."""
    from . import assess
    from .examples.analytic_shapes import SADDLE_I_D, saddle_face
    r = assess(saddle_face(), lref=2.0, rtol=1e-6)
    close(r.signature["I_D"], SADDLE_I_D, "saddle I_D", rel=RTOL_ID)
    close(r.signature["I_D_minus"], SADDLE_I_D, "saddle I_D-", rel=RTOL_ID)
    check(r.signature["I_D_plus"] == 0.0, "saddle I_D+ is %r" % r.signature["I_D_plus"])
    check_fractions(r, [0, 0, 0, 1])


# -- files ---------------------------------------------------------------------------------------
def check_example_hull(folder):
    """The built-in example (half-Wigley Bezier patch written as STEP), read back through the
    reading process: the published reference values, the file's digest recorded."""
    from . import assess
    from .examples.builtin import WIGLEY_REFERENCE, write_builtin_example
    path, lref, _ = write_builtin_example(folder)
    r = assess(path, lref=lref)
    for m in ("I_D", "I_D_plus", "I_D_minus"):
        close(r.signature[m], WIGLEY_REFERENCE[m], "example " + m, rel=2 * WIGLEY_RTOL)
    with open(path, "rb") as fh:
        digest = hashlib.sha256(fh.read()).hexdigest()
    check(r.input.get("sha256") == digest, "example digest %r, file %s" % (r.input.get("sha256"), digest))
    check(r.input.get("representation") == "brep", "example assessed as %s" % r.input.get("representation"))


def write_binary_ply(path, vertices, faces):
    """A binary little-endian PLY of float64 vertices and uint8-counted int32 triangles."""
    V = np.ascontiguousarray(vertices, "<f8")
    F = np.zeros(len(faces), dtype=[("n", "u1"), ("v", "<i4", (3,))])
    F["n"], F["v"] = 3, faces
    header = ("ply\nformat binary_little_endian 1.0\nelement vertex %d\nproperty double x\n"
              "property double y\nproperty double z\nelement face %d\n"
              "property list uchar int vertex_indices\nend_header\n" % (len(V), len(F)))
    with open(path, "wb") as fh:
        fh.write(header.encode("ascii"))
        fh.write(V.tobytes())
        fh.write(F.tobytes())
    return path


def check_mesh_sphere():
    """Icosphere of frequency 12 (vertices on the unit sphere), L_ref = 2: the per-face fit is
    exact there, so I_D = 4 and all elliptic to rounding (mesh path, paper section 3.2)."""
    from .examples.analytic_meshes import icosphere_mesh
    from .mesh.backend import assess_mesh
    r = assess_mesh(icosphere_mesh(12), lref=2.0)
    close(r.signature["I_D"], 4.0, "icosphere I_D", rel=MESH_EXACT)
    close(r.signature["I_D_minus"], 0.0, "icosphere I_D-", abs_=MESH_EXACT)
    check_fractions(r, [0, 0, 1, 0], atol=MESH_EXACT)
    check(r.validity["I_D"].status.value == "VALID", "icosphere I_D %s" % r.validity["I_D"].status.value)


def check_mesh_file(folder):
    """The icosphere as a binary PLY file: the file's signature is the arrays' to rounding, and
    the record names the mesh realization and the format."""
    from . import assess
    from .examples.analytic_meshes import icosphere_mesh
    V, F = icosphere_mesh(12)
    path = write_binary_ply(os.path.join(folder, "icosphere.ply"), V, F)
    r = assess(path, lref=2.0)
    close(r.signature["I_D"], 4.0, "icosphere.ply I_D", rel=MESH_EXACT)
    check(r.input.get("representation") == "mesh" and r.input.get("format") == "ply",
          "icosphere.ply read as %s / %s" % (r.input.get("representation"), r.input.get("format")))


def refused(path, *words):
    """The InputError message assess(path) raises; AssertionError if it assesses, or if the
    message lacks one of words or the file's name."""
    from . import assess
    try:
        assess(path)
    except InputError as exc:
        message = str(exc)
    else:
        raise AssertionError("damaged file %s was assessed" % path)
    check(os.path.basename(path) in message, "the reason does not name the file: %s" % message)
    for w in words:
        check(w in message, "the reason for %s lacks %r: %s" % (os.path.basename(path), w, message))
    return message


def check_damaged_brep(folder):
    """The example STEP cut in half is refused as truncated, with the file named."""
    from .examples.builtin import write_builtin_example
    path, _, _ = write_builtin_example(folder)
    with open(path, "rb") as fh:
        data = fh.read()
    cut = os.path.join(folder, "cut_half_wigley.step")
    with open(cut, "wb") as fh:
        fh.write(data[:len(data) // 2])
    refused(cut, "truncated")


def check_damaged_mesh(folder):
    """A binary PLY cut short and an STL of random bytes are refused, each with a reason."""
    from .examples.analytic_meshes import icosphere_mesh
    path = write_binary_ply(os.path.join(folder, "whole.ply"), *icosphere_mesh(4))
    with open(path, "rb") as fh:
        data = fh.read()
    cut = os.path.join(folder, "cut.ply")
    with open(cut, "wb") as fh:
        fh.write(data[:int(len(data) * 0.6)])
    refused(cut, "truncated")
    noise = os.path.join(folder, "noise.stl")
    with open(noise, "wb") as fh:
        fh.write(np.random.default_rng(1).integers(0, 256, 3001, dtype=np.uint8).tobytes())
    refused(noise)


# -- the document object and export --------------------------------------------------------------
def source_fingerprint(obj):
    """Everything about a Part or Mesh source that an analysis must never change: its
    geometry's digest, measures, placement and label."""
    if hasattr(obj, "Shape"):
        geo = obj.Shape.exportBrepToString()
        extra = (obj.Shape.Area, obj.Shape.Volume, obj.Shape.hashCode())
    else:
        pts, tri = obj.Mesh.Topology
        geo = repr((np.asarray(pts).round(15).tolist(), tri))
        extra = (obj.Mesh.Area, obj.Mesh.Volume, obj.Mesh.CountFacets)
    return (hashlib.sha256(geo.encode()).hexdigest(), extra, str(obj.Placement), obj.Label)


def wigley_feature(doc, name="HalfWigley", L=None):
    """A Part::Feature holding the example hull in doc, scaled to length L (default: as built)."""
    from .examples.builtin import WIGLEY_B, WIGLEY_L, WIGLEY_T, half_wigley_shape
    s = 1.0 if L is None else L / WIGLEY_L
    obj = doc.addObject("Part::Feature", name)
    obj.Shape = half_wigley_shape(WIGLEY_L * s, WIGLEY_B * s, WIGLEY_T * s)
    doc.recompute()
    return obj


def output_properties():
    """Names of the analysis object's stored properties (not its links and files)."""
    from .app.analysis import PROPERTIES
    return [p[1] for p in PROPERTIES if p[0] not in ("App::PropertyLink", "App::PropertyFileIncluded")]


def same_value(a, b):
    return (isinstance(a, float) and isinstance(b, float) and math.isnan(a) and math.isnan(b)) or a == b


def check_analysis_object(folder):
    """make_analysis on a Part feature: the reference values, the source unchanged; saved,
    closed and reopened, every property and the fields as they were, not asking for a
    recompute; touched and recomputed, the same I_D."""
    import FreeCAD
    from .app import HullProdAnalysis, analysis_fields, make_analysis
    from .examples.builtin import WIGLEY_REFERENCE
    doc = FreeCAD.newDocument("HullProdSelfTest")
    try:
        src = wigley_feature(doc)
        before = source_fingerprint(src)
        a = make_analysis(src, lref=1.0)
        check(a.Status == "ok", "analysis status %r" % a.Status)
        close(a.I_D, WIGLEY_REFERENCE["I_D"], "analysis I_D", rel=2 * WIGLEY_RTOL)
        check(source_fingerprint(src) == before, "the analysis changed its source")
        values = {n: getattr(a, n) for n in output_properties() if n != "ComputeSeconds"}
        points = analysis_fields(a).points.copy()
        path, aname = os.path.join(folder, "analysis.FCStd"), a.Name
        doc.saveAs(path)
        FreeCAD.closeDocument(doc.Name)
        doc = FreeCAD.openDocument(path)
        b = doc.getObject(aname)
        check(isinstance(b.Proxy, HullProdAnalysis), "reopened proxy is %r" % b.Proxy)
        changed = [n for n, v in values.items() if not same_value(getattr(b, n), v)]
        check(not changed, "properties changed by save and reopen: %s" % changed)
        check(np.array_equal(analysis_fields(b).points, points), "fields changed by save and reopen")
        check("Touched" not in b.State, "the reopened analysis asks for a recompute")
        b.touch()
        doc.recompute()
        check(b.Status == "ok", "recomputed status %r" % b.Status)
        close(b.I_D, values["I_D"], "recomputed I_D", rel=1e-12)
    finally:
        FreeCAD.closeDocument(doc.Name)


def check_json_export(folder):
    """A result saved as signature.json holds the result's JSON document: every metric with a
    status of the vocabulary, null exactly where not established (paper section 4)."""
    from . import assess
    from .core.validity import Status
    from .examples.builtin import half_wigley_shape
    r = assess(half_wigley_shape(), lref=1.0)
    out = os.path.join(folder, "export")
    r.save(out)
    with open(os.path.join(out, "signature.json")) as fh:
        saved = json.load(fh)
    check(saved == json.loads(r.to_json()), "signature.json differs from the result's JSON")
    labels = {s.value for s in Status}
    for m, rec in saved["validity"].items():
        check(rec["status"] in labels, "%s status %r is not in the vocabulary" % (m, rec["status"]))
        check((rec["value"] is None) == (not r.validity[m].established),
              "%s value %r with status %s" % (m, rec["value"], rec["status"]))
    check(os.path.isfile(os.path.join(out, "fields.vtp")), "no fields.vtp written")
