"""App-side objects headless: the HullProdAnalysis feature, make_analysis, recompute on
source change, save/reload, export, probe, compare, selection parsing, preferences,
package metadata, and the App/GUI split (no non-GUI module imports FreeCADGui or Qt)."""
import csv
import json
import math
import os
import subprocess
import sys
import xml.etree.ElementTree as ET

import numpy as np
import pytest

from conftest import ROOT, needs_freecad, shared_hull
from hullprod_wb.selftest import source_fingerprint as fingerprint, wigley_feature

pytestmark = needs_freecad

# With a fixed L_ref, I_D of the hull scaled by s is I_D / s^2 (K scales as 1/s^2); the
# adaptive quadrature (default rtol 1e-4) reproduces that to better than 1e-3.
SCALE_RTOL = 1e-3


@pytest.fixture(scope="module")
def fc():
    from hullprod_wb.freecad_env import import_freecad
    FreeCAD = import_freecad()
    import Mesh  # noqa: F401
    return FreeCAD


@pytest.fixture
def doc(fc):
    d = fc.newDocument("HullProdTest")
    name = d.Name
    yield d
    if name in fc.listDocuments():
        fc.closeDocument(name)


def mesh_feature(doc, V, F, name="Mesh"):
    import Mesh
    obj = doc.addObject("Mesh::Feature", name)
    obj.Mesh = Mesh.Mesh(np.asarray(V)[np.asarray(F)].tolist())
    doc.recompute()
    return obj


# -- App/GUI split -------------------------------------------------------------------------------
def test_non_gui_modules_import_no_gui():
    code = r"""
import importlib, json, pkgutil, sys
sys.path.insert(0, %r)
from hullprod_wb.freecad_env import import_freecad
FreeCAD = import_freecad()
import hullprod_wb
names, failed = [], {}
for m in pkgutil.walk_packages(hullprod_wb.__path__, "hullprod_wb."):
    if m.name == "hullprod_wb.gui" or m.name.startswith("hullprod_wb.gui."):
        continue
    try:
        importlib.import_module(m.name)
        names.append(m.name)
    except Exception as exc:
        failed[m.name] = "%%s: %%s" %% (type(exc).__name__, exc)
gui = sorted(k for k in sys.modules if k == "FreeCADGui" or k.split(".")[0] in ("PySide", "PySide2", "PySide6", "pivy"))
print(json.dumps({"modules": names, "failed": failed, "gui": gui, "GuiUp": bool(FreeCAD.GuiUp)}))
""" % ROOT
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=240)
    assert res.returncode == 0, res.stderr[-3000:]
    out = json.loads(res.stdout.strip().splitlines()[-1])
    assert "hullprod_wb.app.analysis" in out["modules"] and "hullprod_wb.app.probe" in out["modules"]
    assert out["failed"] == {}, out["failed"]
    assert out["gui"] == [], "non-GUI modules imported GUI modules: %s" % out["gui"]
    assert out["GuiUp"] is False


# -- creation, properties -----------------------------------------------------------------------
def test_make_analysis_brep_properties(doc):
    import hullprod_wb
    from hullprod_wb.app import HullProdAnalysis, make_analysis, signature_of
    from hullprod_wb.core.constants import METRICS
    from hullprod_wb.core.validity import Status
    src = wigley_feature(doc)
    before = fingerprint(src)
    a = make_analysis(src, lref=1.0)
    assert a.TypeId == "App::FeaturePython" and isinstance(a.Proxy, HullProdAnalysis)
    assert a.Source is src and list(a.Faces) == [] and a.FacesUsed == [1]
    assert a.Status == "ok" and a.Representation == "brep"
    assert (a.LrefMode, a.LrefExplicit, a.LrefUsed, a.LrefUsedMode) == ("explicit", 1.0, 1.0, "explicit")
    assert a.TauH == pytest.approx(a.Hf / 1.0, rel=1e-15) and a.TauK == pytest.approx(a.Kf, rel=1e-15)
    direct = hullprod_wb.assess(src, lref=1.0, h_f=a.Hf, k_f=a.Kf, order=a.QuadratureOrder,
                                rtol=a.QuadratureRtol, max_depth=a.QuadratureMaxDepth)
    doc_json = json.loads(a.ResultJSON)
    labels = {s.value for s in Status}
    sig = signature_of(a)
    for m in METRICS:
        rec = direct.validity[m]
        assert getattr(a, m + "_Status") == rec.status.value in labels
        assert getattr(a, m + "_Established") is rec.established
        assert doc_json["validity"][m]["status"] == rec.status.value
        if rec.value is None:
            assert math.isnan(getattr(a, m)) and sig[m]["value"] is None
        else:  # the same deterministic computation: identical to the last bits
            assert getattr(a, m) == pytest.approx(rec.value, rel=1e-12)
            assert doc_json["validity"][m]["value"] == pytest.approx(rec.value, rel=1e-12)
    assert a.RepresentedArea == pytest.approx(direct.integrals.represented_area, rel=1e-12)
    from hullprod_wb.app import analysis_fields
    f = analysis_fields(a)
    assert f is not None and f.points.shape[1] == 3 and len(f.triangles) > 10
    assert len(f.extra["face_id"]) == len(f.points)
    assert fingerprint(src) == before


def test_make_analysis_uses_preferences(doc):
    from hullprod_wb.app import make_analysis, preferences
    src = wigley_feature(doc)
    try:
        preferences.set("DefaultHf", 3e-4)
        preferences.set("DefaultKf", 2e-4)
        a = make_analysis(src)
        assert (a.Hf, a.Kf, a.LrefMode, a.LrefUsedMode) == (3e-4, 2e-4, "automatic", "automatic")
        assert a.LrefUsed == pytest.approx(a.LrefAutomatic, rel=1e-15)
        b = make_analysis(src, h_f=1e-3)
        assert b.Hf == 1e-3 and b.Kf == 2e-4
    finally:
        preferences.reset()
    assert preferences.get("DefaultHf") == 1e-4


def test_recompute_after_source_change(doc):
    from hullprod_wb.app import make_analysis
    from hullprod_wb.examples.builtin import half_wigley_shape
    src = wigley_feature(doc)
    a = make_analysis(src, lref=1.0)
    i_d, span = a.I_D, a.LrefAutomatic
    assert a.I_D_Established and i_d > 0
    src.Shape = half_wigley_shape(2.0, 0.2, 0.125)  # the same hull, twice as large
    doc.recompute()
    assert a.Status == "ok"
    import hullprod_wb
    direct = hullprod_wb.assess(src, lref=1.0, order=a.QuadratureOrder, rtol=a.QuadratureRtol,
                                max_depth=a.QuadratureMaxDepth)  # the same computation: identical
    assert a.I_D == pytest.approx(direct.validity["I_D"].value, rel=1e-12)
    assert a.I_D == pytest.approx(i_d / 4.0, rel=SCALE_RTOL)
    assert a.LrefAutomatic == pytest.approx(2.0 * span, rel=1e-6)  # span of resampled surface
    a.LrefExplicit = 2.0  # a parameter change recomputes too; scaled L_ref restores I_D
    doc.recompute()
    assert a.I_D == pytest.approx(i_d, rel=SCALE_RTOL)
    assert json.loads(a.ResultJSON)["reference_length"]["value"] == 2.0


def test_source_never_modified_mesh(doc):
    from hullprod_wb.app import make_analysis
    from hullprod_wb.examples.analytic_meshes import icosphere_mesh
    src = mesh_feature(doc, *icosphere_mesh(6, radius=2.0))
    before = fingerprint(src)
    a = make_analysis(src)
    assert a.Representation == "mesh" and a.Status == "ok"
    assert a.a_elliptic_Established and a.a_elliptic > 0.9  # a sphere is elliptic everywhere
    assert fingerprint(src) == before


def test_save_and_reload_round_trip(doc, fc, tmp_path):
    from hullprod_wb.app import HullProdAnalysis, analysis_fields, make_analysis
    from hullprod_wb.app.analysis import PROPERTIES
    src = wigley_feature(doc)
    a = make_analysis(src, lref=1.0, order=6, rtol=2e-4, max_depth=6)
    names = [p[1] for p in PROPERTIES if p[0] not in ("App::PropertyLink", "App::PropertyFileIncluded")]
    values = {n: getattr(a, n) for n in names}
    pts = analysis_fields(a).points.copy()
    path = str(tmp_path / "analysis.FCStd")
    doc.saveAs(path)
    name, aname = doc.Name, a.Name
    fc.closeDocument(name)
    d2 = fc.openDocument(path)
    try:
        b = d2.getObject(aname)
        assert isinstance(b.Proxy, HullProdAnalysis) and b.Proxy.Type == "HullProdAnalysis"
        assert b.Source.Name == "HalfWigley"
        for n in names:
            v = getattr(b, n)
            if isinstance(v, float) and math.isnan(v):
                assert math.isnan(values[n]), n
            elif n == "ComputeSeconds":  # a timing: FreeCAD keeps 16 decimals of it
                assert v == pytest.approx(values[n], abs=1e-15)
            else:  # outputs are restored from the JSON document with every digit
                assert v == values[n], n
                assert v == values[n], n
        assert np.array_equal(analysis_fields(b).points, pts)
        assert (b.QuadratureOrder, b.QuadratureRtol, b.QuadratureMaxDepth) == (6, 2e-4, 6)
        assert "Touched" not in b.State  # reopening does not ask for a recompute
        b.touch()
        d2.recompute()  # the restored proxy recomputes
        assert b.Status == "ok" and b.I_D == pytest.approx(values["I_D"], rel=1e-12)
        state = b.Proxy.__getstate__()
        assert b.Proxy.dumps() == state and json.loads(json.dumps(state))["Type"] == "HullProdAnalysis"
    finally:
        fc.closeDocument(d2.Name)


# -- faces, errors, cancellation -------------------------------------------------------------------
def test_faces_from_subelements():
    from hullprod_wb.app.selection import faces_from_subelements
    assert faces_from_subelements(["Face3", "Edge2", "Face1", "Face3"]) == [1, 3]
    assert faces_from_subelements(["Edge1", "Vertex2"]) is None
    assert faces_from_subelements([]) is None


def test_selected_faces_only(doc):
    import Part
    from hullprod_wb.app import make_analysis
    from hullprod_wb.app.selection import sources_from_selection
    cyl = doc.addObject("Part::Feature", "Cylinder")
    cyl.Shape = Part.makeCylinder(1.0, 3.0)
    doc.recompute()
    lateral = [i + 1 for i, f in enumerate(cyl.Shape.Faces) if "Cylinder" in type(f.Surface).__name__]
    assert len(lateral) == 1
    sel = sources_from_selection([(cyl, ["Face%d" % lateral[0]])])
    assert sel == [(cyl, lateral)]
    a = make_analysis(cyl, faces=sel[0][1], lref=3.0)
    assert list(a.FacesUsed) == lateral and list(a.Faces) == lateral
    assert a.RepresentedArea == pytest.approx(2 * math.pi * 1.0 * 3.0, rel=1e-6)  # lateral area only
    assert a.a_single_Established and a.a_single == pytest.approx(1.0, abs=1e-9)  # singly curved
    assert a.I_D_Established and a.I_D == pytest.approx(0.0, abs=1e-9)  # K = 0 on a cylinder


def test_bad_input_leaves_no_object(doc):
    from hullprod_wb.app import make_analysis
    from hullprod_wb.app.selection import sources_from_selection
    from hullprod_wb.core.errors import InputError
    from hullprod_wb.examples.analytic_meshes import plane_mesh
    src = wigley_feature(doc)
    n = len(doc.Objects)
    with pytest.raises(InputError, match="reference length"):
        make_analysis(src, lref=-1.0)
    with pytest.raises(InputError, match="out of range|does not exist"):
        make_analysis(src, faces=[7])
    mesh = mesh_feature(doc, *plane_mesh(4))
    with pytest.raises(InputError, match="mesh"):
        make_analysis(mesh, faces=[1])
    with pytest.raises(InputError, match="document object"):
        make_analysis("not an object")
    assert len(doc.Objects) == n + 1  # only the mesh source was added
    with pytest.raises(InputError, match="select"):
        sources_from_selection([])


def test_cancel_leaves_no_object(doc):
    from hullprod_wb.app import make_analysis
    from hullprod_wb.app.progress import RunProgress
    from hullprod_wb.core.progress import Cancelled
    src = wigley_feature(doc)
    n = len(doc.Objects)
    prog = RunProgress(use_indicator=False)
    prog.cancel()
    with pytest.raises(Cancelled):
        make_analysis(src, progress=prog)
    assert len(doc.Objects) == n
    seen = []
    make_analysis(src, progress=lambda f, msg: seen.append(f))
    assert seen and min(seen) >= 0.0 and max(seen) <= 1.0


# -- export, probe, compare -----------------------------------------------------------------------
def test_export_analysis(doc, tmp_path):
    from hullprod_wb.app import export_analysis, make_analysis, register_report_writer
    from hullprod_wb.app import export as export_mod
    from hullprod_wb.core.errors import InputError
    src = wigley_feature(doc)
    a = make_analysis(src, lref=1.0)
    calls = []
    register_report_writer("test_report", lambda obj, d, f, folder: calls.append(obj.Name) or
                           os.path.join(folder, "report.txt"))
    try:
        paths = export_analysis(a, str(tmp_path / "out"))
    finally:
        export_mod.REPORT_WRITERS.pop("test_report")
    assert calls == [a.Name] and set(paths) == {"json", "csv", "vtp", "fields_csv", "test_report"}
    with open(paths["json"]) as fh:
        assert json.load(fh) == json.loads(a.ResultJSON)
    with open(paths["csv"]) as fh:
        row = next(csv.DictReader(fh))
    assert float(row["I_D"]) == pytest.approx(a.I_D, rel=1e-12) and row["I_D_status"] == a.I_D_Status
    # a FreeCAD object has no file: the row names it and carries the sha256 of its shape
    assert row["input"].startswith("FreeCAD object %s (%s)" % (src.Name, src.Label)) and len(row["sha256"]) == 64
    # the length and area columns name their unit, the document's working unit
    unit = json.loads(a.ResultJSON)["provenance"]["units"]["working_unit"]
    assert "FreeCAD: mm" in unit
    assert {"L_ref [%s]" % unit, "represented_area [%s^2]" % unit, "valid_area [%s^2]" % unit} <= set(row)
    assert float(row["L_ref [%s]" % unit]) == 1.0
    root = ET.parse(paths["vtp"]).getroot()
    piece = root.find("PolyData/Piece")
    from hullprod_wb.app import analysis_fields
    assert int(piece.get("NumberOfPoints")) == len(analysis_fields(a).points)
    with pytest.raises(InputError, match="not empty"):
        export_analysis(a, str(tmp_path / "out"))
    assert set(export_analysis(a, str(tmp_path / "out"), overwrite=True, formats=["json"])) == {"json"}


def test_locate_triangle_and_interpolation():
    from hullprod_wb.app.probe import interpolate_fields, locate_triangle
    from hullprod_wb.core.fields import DistributedFields
    P = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], float)
    T = np.array([[0, 1, 2], [0, 2, 3]])
    idx, bary, dist = locate_triangle(P, T, (0.75, 0.25, 0.0))
    assert idx == 0 and dist == pytest.approx(0.0, abs=1e-15)
    assert bary == pytest.approx([0.25, 0.5, 0.25], abs=1e-12)
    idx, bary, _ = locate_triangle(P, T, (0.2, 0.7, 0.0))
    assert idx == 1
    K = np.array([1.0, 2.0, 3.0, 4.0])
    f = DistributedFields(P, T, K, 0.5 * np.sqrt(K) * 2, np.ones(4, bool), lref=2.0, tau_H=1e-4, tau_K=1e-4)
    r = interpolate_fields(f, (0.75, 0.25, 0.0))
    assert r["K"] == pytest.approx(0.25 * 1 + 0.5 * 2 + 0.25 * 3, rel=1e-12)
    assert r["q_D"] == pytest.approx(r["K"] * 4.0, rel=1e-12) and r["class_id"] == 2 and r["exact"] is False
    # a corner without valid curvature: no value, principal curvatures included, and why
    extra = {"k1": np.full(4, 2.0), "k2": np.full(4, 0.5)}
    g = DistributedFields(P, T, K, np.ones(4), np.array([True, False, True, True]), lref=2.0, tau_H=1e-4,
                          tau_K=1e-4, extra=extra)
    r = interpolate_fields(g, (0.75, 0.25, 0.0))
    assert all(np.isnan(r[k]) for k in ("K", "H", "k1", "k2", "q_D")) and r["class_id"] == -1
    assert "without valid curvature" in r["method"]
    assert interpolate_fields(g, (0.2, 0.7, 0.0))["k1"] == pytest.approx(2.0, rel=1e-12)


def test_probe_mesh_and_brep(doc):
    from hullprod_wb.app import analysis_fields, make_analysis, probe_analysis
    from hullprod_wb.examples.analytic_meshes import icosphere_mesh
    mesh = mesh_feature(doc, *icosphere_mesh(6, radius=2.0))
    m = make_analysis(mesh)
    f = analysis_fields(m)
    tri = f.triangles[5]
    c = f.points[tri].mean(axis=0)
    r = probe_analysis(m, c)
    assert r["exact"] is False and "interpolated" in r["method"]
    assert r["K"] == pytest.approx(float(np.mean(f.K[tri])), rel=1e-9)  # barycentre: plain mean
    assert r["class_name"] == "elliptic"
    src = wigley_feature(doc)
    a = make_analysis(src, lref=1.0)
    # Exact Gaussian curvature of the Wigley surface y = B/2 f(x) g(z) at x = 0, z = -T/2:
    # y_x = 0, y_xx = -4B/L^2 g, y_z = B/2 f g', y_zz = -B/T^2 f; K = y_xx y_zz / (1 + |grad y|^2)^2.
    from hullprod_wb.examples.builtin import WIGLEY_B as B, WIGLEY_L as L, WIGLEY_T as T
    z = -T / 2
    g, gp = 1 - (z / T) ** 2, -2 * z / T ** 2
    y = B / 2 * g
    K_exact = (-4 * B / L ** 2 * g) * (-B / T ** 2) / (1 + (B / 2 * gp) ** 2) ** 2
    r = probe_analysis(a, (0.0, y, z))
    assert r["exact"] is True and r["face"] == 1 and "exact" in r["method"]
    assert r["K"] == pytest.approx(K_exact, rel=1e-6)  # projection of an on-surface point: exact
    assert r["q_D"] == pytest.approx(abs(K_exact), rel=1e-6) and r["class_name"] == "elliptic"


def test_compare_flags(doc):
    from hullprod_wb.app import compare_analyses, make_analysis
    from hullprod_wb.core.errors import InputError
    from hullprod_wb.examples.analytic_meshes import half_wigley_mesh
    src = wigley_feature(doc)
    a = make_analysis(src, lref=1.0)
    b = make_analysis(src, lref=1.0)
    same = compare_analyses([a, b])
    assert same["flags"] == [] and same["values"]["I_D"][0] == same["values"]["I_D"][1]
    mesh = mesh_feature(doc, *half_wigley_mesh(24, 8))
    c = make_analysis(mesh, h_f=1e-3)
    cmp = compare_analyses([a, c])
    text = " ".join(cmp["flags"])
    assert "different representations" in text and "different L_ref modes" in text
    assert "different class thresholds" in text
    with pytest.raises(InputError):
        compare_analyses([a])


def test_shared_mesh_hull(doc):
    import Mesh
    from hullprod_wb.app import make_analysis
    path = shared_hull("mesh/wigley_full.stl")
    src = doc.addObject("Mesh::Feature", "WigleyFull")
    src.Mesh = Mesh.Mesh(path)
    before = fingerprint(src)
    a = make_analysis(src, lref=1.0)
    assert a.Status == "ok" and a.Representation == "mesh" and a.LrefUsed == 1.0
    assert all(getattr(a, m + "_Status") for m in ("I_D", "a_flat"))
    assert fingerprint(src) == before


# -- package metadata and icons ----------------------------------------------------------------
def test_package_xml_for_addon_manager(fc):
    from hullprod_wb import __version__
    meta = fc.Metadata(os.path.join(ROOT, "package.xml"))
    assert meta.Name == "HullProd" and meta.Description
    assert [int(x) for x in meta.Version.split(".")] >= [0, 1, 0]
    assert meta.Version == __version__
    assert any(lic["name"] == "MIT" for lic in meta.License)  # SPDX identifier
    assert any(u["type"] == "repository" and u["location"].startswith("https://") for u in meta.Urls)
    assert meta.Maintainer and meta.Maintainer[0]["name"]
    assert meta.FreeCADMin.startswith("0.20")
    deps = {d["package"] for d in meta.Depend}
    assert {"numpy", "scipy", "trimesh"} <= deps
    wb = meta.Content["workbench"][0]
    assert wb.Classname == "HullProdWorkbench" and wb.Name == "HullProd"
    assert os.path.isdir(os.path.join(ROOT, wb.Subdirectory))
    with open(os.path.join(ROOT, wb.Subdirectory, "InitGui.py")) as fh:
        assert "class %s(" % wb.Classname in fh.read()
    for icon in (meta.Icon, wb.Icon):
        assert os.path.isfile(os.path.join(ROOT, icon))
    date = ET.parse(os.path.join(ROOT, "package.xml")).getroot().find("{https://wiki.freecad.org/Package_Metadata}date")
    assert date is not None and len(date.text.split("-")) == 3


def test_icons_small_valid_svg():
    from hullprod_wb.gui.icons import ICON_DIR
    names = {"HullProd", "HullProd_Analyze", "HullProd_ShowDevelopability", "HullProd_ShowClasses",
             "HullProd_ShowSignedDevelopability", "HullProd_ShowPlates", "HullProd_ValidityPanel",
             "HullProd_Probe", "HullProd_Compare", "HullProd_Export"}
    for n in names:
        path = os.path.join(ICON_DIR, n + ".svg")
        assert os.path.getsize(path) < 10 * 1024, path
        assert ET.parse(path).getroot().tag.endswith("svg")


def test_compare_flags_reference_lengths_that_differ(doc):
    """Two automatic analyses whose L_ref differ (a hull and the same hull twice as long):
    I_D scales with L_ref^2, so the comparison says so."""
    from hullprod_wb.app import compare_analyses, make_analysis
    from hullprod_wb.examples.builtin import WIGLEY_L
    a = make_analysis(wigley_feature(doc), order=4, rtol=1e-3, max_depth=3)
    b = make_analysis(wigley_feature(doc, "Long", L=2 * WIGLEY_L), order=4, rtol=1e-3, max_depth=3)
    flags = [f for f in compare_analyses([a, b])["flags"] if f.startswith("L_ref differs")]
    assert len(flags) == 1 and "factor 2" in flags[0] and "L_ref^2" in flags[0]


def test_units_in_words(doc):
    """Every analysis names its length unit (a mesh without one: 'mesh units', never '?'),
    and areas read in m\u00b2 for a millimetre hull, in mm\u00b2 for a millimetre part, one unit
    per table (chosen by the reference area)."""
    from hullprod_wb.app import compare_analyses, make_analysis
    from hullprod_wb.app.analysis import length_unit_label
    from hullprod_wb.examples.analytic_meshes import half_wigley_mesh
    from hullprod_wb.gui.wording import area_text
    a = make_analysis(wigley_feature(doc), lref=1.0, order=4, rtol=1e-3, max_depth=3)
    m = make_analysis(mesh_feature(doc, *half_wigley_mesh(24, 8)), lref=1.0)
    assert length_unit_label(a) == "mm" and length_unit_label(m) == "mesh units"
    cmp = compare_analyses([a, m])
    assert [c["units"] for c in cmp["context"]] == ["mm", "mesh units"]
    unit_flags = [f for f in cmp["flags"] if f.startswith("different length units")]
    assert unit_flags and "?" not in unit_flags[0] and "mesh units" in unit_flags[0]
    assert area_text(6.00408e6, "mm") == "6.00408 m\u00b2"
    assert area_text(0.074, "mm") == "0.074 mm\u00b2"
    assert area_text(0.074, "mm", reference=6.0e6) == "7.4e-08 m\u00b2"  # a sliver in a hull's table
    assert area_text(23918.9, "mesh units") == "23918.9 (mesh units)\u00b2"
    assert area_text(2.5, "ft") == "2.5 ft\u00b2" and area_text(None, "mm") == "n/a"


def test_console_mode_records_the_object(doc):
    """Without the GUI the assessment runs in this process; its input record names the
    object and carries the sha256 of the shape's BRep text (what an export writes)."""
    from hullprod_wb.app import make_analysis
    from hullprod_wb.app.assessment_process import object_record
    src = wigley_feature(doc)
    a = make_analysis(src, lref=1.0, order=4, rtol=1e-3, max_depth=3)
    inp = json.loads(a.ResultJSON)["input"]
    assert inp["name"] == src.Label and inp["format"] == "freecad-shape" and inp["path"] is None
    assert inp["sha256"] == object_record(src)["sha256"] and len(inp["sha256"]) == 64
    assert a.InputSha256 == inp["sha256"]


def test_assessment_process_gives_the_in_process_signature(doc):
    """The GUI's assessment process (a fresh interpreter given the shape's BRep text) gives
    the signature of an assessment in this process, and its automatic L_ref proposal is the
    L_ref the run then uses."""
    from hullprod_wb.app import make_analysis
    from hullprod_wb.app.assessment_process import AssessmentProcess
    src = wigley_feature(doc)
    here = make_analysis(src, order=4, rtol=1e-3, max_depth=3)
    proc = AssessmentProcess(src)
    try:
        proc.run({"order": 4, "rtol": 1e-3, "max_depth": 3})
        a = proc.wait()
    finally:
        proc.close()
    assert proc.lref == a.reference_length.value == pytest.approx(here.LrefUsed, rel=1e-12)
    for m in ("I_D", "I_D_plus", "I_D_minus", "a_elliptic", "a_saddle"):
        assert a.validity[m].value == pytest.approx(getattr(here, m), rel=1e-9, abs=1e-12), m
    assert a.input["name"] == src.Label and not os.path.exists(proc.folder)


def test_assessment_process_cancel_ends_it_at_once(doc):
    """cancel() during a long run ends the process (and what it started) within a second."""
    from hullprod_wb.app.assessment_process import AssessmentProcess
    proc = AssessmentProcess(wigley_feature(doc))
    try:
        proc.run({"order": 8, "rtol": 1e-12, "max_depth": 14})
        cancel_once_running(proc)
    finally:
        proc.close()


def cancel_once_running(proc):
    """Cancel proc after its first progress; it and what it started must be gone within a
    second."""
    import time
    t = time.monotonic()
    while proc.last_progress is None and time.monotonic() - t < 60:
        proc.poll(0.05)
    assert proc.state == "running", proc.error
    t = time.monotonic()
    proc.cancel()
    assert proc.proc.poll() is not None and time.monotonic() - t < 1.0
    assert proc.state == "cancelled"
    while living_in_group(proc.proc.pid) and time.monotonic() - t < 1.0:  # SIGKILL takes effect
        time.sleep(0.01)
    assert living_in_group(proc.proc.pid) == []  # nothing it started runs on, within a second


def living_in_group(pgid):
    """Processes of process group pgid that are not zombies (/proc)."""
    out = []
    for pid in os.listdir("/proc"):
        if not pid.isdigit():
            continue
        try:
            with open("/proc/%s/stat" % pid) as fh:
                fields = fh.read().rsplit(")", 1)[1].split()
        except OSError:
            continue
        if int(fields[2]) == pgid and fields[0] != "Z":
            out.append(int(pid))
    return out


def test_skip_planar_faces_recorded(doc):
    """SkipPlanarFaces leaves out the planar caps of a cylinder and records them."""
    import Part
    from hullprod_wb.app import make_analysis
    from hullprod_wb.app.planar import planar_faces
    cyl = doc.addObject("Part::Feature", "Cyl")
    cyl.Shape = Part.makeCylinder(0.02, 0.1)
    doc.recompute()
    lateral = [i + 1 for i, f in enumerate(cyl.Shape.Faces) if "Cylinder" in type(f.Surface).__name__]
    assert planar_faces(cyl.Shape) == sorted(set(range(1, 4)) - set(lateral))
    a = make_analysis(cyl, skip_planar=True, order=4, rtol=1e-3, max_depth=3)
    inp = json.loads(a.ResultJSON)["input"]
    assert list(a.FacesUsed) == lateral and inp["planar_faces_left_out"] == planar_faces(cyl.Shape)
    assert a.a_single == pytest.approx(1.0, abs=1e-9)


def test_locate_triangle_passes_over_degenerate_triangles_without_warning():
    """A display mesh may hold zero-area triangles (a collapsed edge, a sliver at a seam):
    they hold no point, and locating a point near them raises no floating-point warning."""
    import warnings
    from hullprod_wb.app.probe import locate_triangle
    a, b = np.array([0.1, 0.2, 0.3]), np.array([0.4, 0.5, 0.7])
    # a repeated vertex; three points on one line in floating point; a proper triangle
    P = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], a, b, a + 3.0 * (b - a)])
    T = np.array([[3, 4, 3], [3, 4, 5], [0, 1, 2]])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        idx, bary, dist = locate_triangle(P, T, (0.25, 0.25, 0.1))
    assert idx == 2
    assert np.allclose(bary, [0.5, 0.25, 0.25]) and abs(dist - 0.1) < 1e-12


def finish_study(proc, seconds=300):
    """Poll a study's process until it ends; its progress events."""
    import time
    t, events = time.monotonic(), []
    while not proc.finished and time.monotonic() - t < seconds:
        events += [ev for ev in proc.poll(0.1) if ev.get("event") == "progress"]
    return events


def test_threshold_study_process_repeats_the_analysis(doc):
    """A threshold study of an analysis, run in the assessment process on what Analyze
    sent, with the analysis's L_ref and quadrature settings: the row at the analysis's
    h_f = k_f has the analysis's I_D to 1e-9 and its statuses; the study names the object,
    and its progress moves through every tolerance."""
    from hullprod_wb.app import make_analysis
    from hullprod_wb.app.assessment_process import AssessmentProcess
    from hullprod_wb.app.study_run import study_settings
    src = wigley_feature(doc)
    here = make_analysis(src, order=4, rtol=1e-3, max_depth=3, h_f=2e-4, k_f=2e-4)
    source, faces, options = study_settings(here)
    assert source is src and options["lref"] == here.LrefUsed and options["order"] == 4
    proc = AssessmentProcess(src, faces, propose=False)
    try:
        proc.run_study("thresholds", options)
        events = finish_study(proc)
        study = proc.study_result()
    finally:
        proc.close()
    rows = {r["h_f"]: r for r in study["rows"]}
    assert sorted(rows) == [1e-5, 1e-4, 2e-4, 1e-3]
    row = rows[2e-4]
    for m, key in (("I_D", "I_D"), ("I_D_plus", "I_D_plus"), ("I_D_minus", "I_D_minus")):
        assert row[key] == pytest.approx(getattr(here, m), rel=1e-9, abs=1e-12), m
        assert row["status"][key] == getattr(here, m + "_Status"), m
    assert row["a_C"]["flat"] == pytest.approx(here.a_flat, rel=1e-9, abs=1e-12)
    assert study["lref"] == here.LrefUsed and study["input"]["name"] == src.Label
    assert study["input"]["path"] is None
    fractions = [ev["fraction"] for ev in events]
    assert fractions == sorted(fractions) and len({round(f, 1) for f in fractions}) >= 4, fractions


def test_study_process_cancel_ends_it_at_once(doc):
    """Cancelling a study ends its process and what it started within a second."""
    from hullprod_wb.app import make_analysis
    from hullprod_wb.app.assessment_process import AssessmentProcess
    from hullprod_wb.app.study_run import study_settings
    here = make_analysis(wigley_feature(doc), order=4, rtol=1e-3, max_depth=3)
    source, faces, options = study_settings(here)
    options.update(order=8, rtol=1e-12, max_depth=14)
    proc = AssessmentProcess(source, faces, propose=False)
    try:
        proc.run_study("thresholds", options)
        cancel_once_running(proc)
    finally:
        proc.close()


def test_study_report_default_beside_the_document_named_after_the_object():
    from hullprod_wb.app.study_run import default_report_path
    assert default_report_path("/d/ship.FCStd", "KCS hull/v2", "thresholds") == "/d/KCS_hull_v2_thresholds_study.html"
    assert default_report_path("", "Hull", "sameface", home="/h") == "/h/Hull_sameface_study.html"
