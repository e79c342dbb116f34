"""The parametric analysis object: App::FeaturePython 'HullProdAnalysis'.

It links its source (a Part or Mesh object, optionally some BRep faces), reruns the
assessment in execute() whenever the source or a parameter changes, and keeps every
result in App properties: the seven signature entries (float, NaN when not established)
with status, established flag and reason per metric, L_ref used, thresholds, areas,
representation, the full JSON document and the distributed fields (a .npz file included
in the document). The source object is only read, never modified.

No GUI import at module level: the view provider is attached only when FreeCAD.GuiUp.
"""
import json
import math
import os
import shutil
import tempfile
import time

from ..core.constants import METRICS
from ..core.errors import InputError
from ..brep.validity.budget import DEFAULT_QUADRATURE, PROTOCOLS
from ..core.progress import Cancelled
from . import preferences
from .progress import RunProgress

TYPE = "HullProdAnalysis"
#: Version of the proxy state; onDocumentRestored adds properties introduced later.
STATE_VERSION = 1

LREF_MODES = ["automatic", "explicit"]
STATUS_NOT_COMPUTED = "not computed"
STATUS_OK = "ok"

#: The backend's defaults of the quadrature settings added after the first documents were saved.
QUADRATURE_DEFAULTS = {"QuadratureProtocol": DEFAULT_QUADRATURE.protocol,
                       "QuadraturePointBudget": DEFAULT_QUADRATURE.point_budget,
                       "QuadratureDepthLimit": DEFAULT_QUADRATURE.depth_limit}

#: (type, name, group, tooltip, output). Output properties are written by execute() only.
PROPERTIES = [
    ("App::PropertyLink", "Source", "Source", "Part or Mesh object assessed (never modified)", False),
    ("App::PropertyIntegerList", "Faces", "Source",
     "BRep faces to assess, FreeCAD numbering (Face3 -> 3); empty: all faces", False),
    ("App::PropertyBool", "SkipPlanarFaces", "Source",
     "BRep: leave out planar faces (deck, transom, flat plates closing the shape)", False),
    ("App::PropertyBool", "AutoUpdate", "Source",
     "GUI: when the source changes, reassess it in the background (the faces that did not change come "
     "from the faces' store); off: a recompute marks the results out of date", False),
    ("App::PropertyEnumeration", "LrefMode", "Parameters",
     "automatic: principal-axis span of the surface; explicit: LrefExplicit", False),
    ("App::PropertyFloat", "LrefExplicit", "Parameters",
     "explicit reference length L_ref in the source's length units (e.g. L_pp)", False),
    ("App::PropertyPrecision", "Hf", "Parameters", "dimensionless mean-curvature tolerance h_f (tau_H = h_f/L_ref)", False),
    ("App::PropertyPrecision", "Kf", "Parameters",
     "dimensionless Gaussian-curvature tolerance k_f (tau_K = k_f/L_ref^2)", False),
    ("App::PropertyInteger", "QuadratureOrder", "Parameters", "BRep: Gauss-Legendre order per direction", False),
    ("App::PropertyPrecision", "QuadratureRtol", "Parameters", "BRep: local relative tolerance of the quadrature", False),
    ("App::PropertyEnumeration", "QuadratureProtocol", "Parameters",
     "BRep: budget (refinement by the error estimates within the point budget, tolerance on the "
     "shape's totals) or paper (each face to the maximum depth, rechecked one level deeper)", False),
    ("App::PropertyInteger", "QuadraturePointBudget", "Parameters",
     "BRep, budget protocol: field points of the whole assessment, shared by the faces by area", False),
    ("App::PropertyInteger", "QuadratureDepthLimit", "Parameters",
     "BRep, budget protocol: levels a cell may be refined below its patch", False),
    ("App::PropertyInteger", "QuadratureMaxDepth", "Parameters",
     "BRep: depth of the paper protocol (under budget it bounds only the halving of few patches)", False),
    ("App::PropertyString", "Status", "Results", "ok | not computed | cancelled: ... | error: ...", True),
    ("App::PropertyString", "Representation", "Results", "brep (native surfaces) or mesh (triangles)", True),
    ("App::PropertyString", "Backend", "Results", "realization that computed the signature", True),
    ("App::PropertyFloat", "LrefUsed", "Results", "reference length L_ref used, source length units", True),
    ("App::PropertyFloat", "LrefAutomatic", "Results", "automatic proposal (principal-axis span)", True),
    ("App::PropertyString", "LrefUsedMode", "Results", "how the L_ref used was chosen", True),
    ("App::PropertyString", "LrefMethod", "Results", "method of the L_ref used", True),
    ("App::PropertyString", "LrefWarning", "Results", "plausibility warning on L_ref, if any", True),
    ("App::PropertyPrecision", "TauH", "Results", "mean-curvature threshold tau_H = h_f / L_ref", True),
    ("App::PropertyPrecision", "TauK", "Results", "Gaussian-curvature threshold tau_K = k_f / L_ref^2", True),
    ("App::PropertyFloat", "RepresentedArea", "Results", "area of everything represented", True),
    ("App::PropertyFloat", "ValidArea", "Results", "area of the valid Gaussian-curvature domain A_K", True),
    ("App::PropertyIntegerList", "FacesUsed", "Results", "BRep faces that were assessed", True),
    ("App::PropertyString", "InputSha256", "Results", "sha256 of the input file, when read from a file", True),
    ("App::PropertyString", "Units", "Results", "length units of the representation", True),
    ("App::PropertyStringList", "Warnings", "Results", "warnings of the last run", True),
    ("App::PropertyFloat", "ComputeSeconds", "Results", "wall time of the last run", True),
    ("App::PropertyString", "ResultJSON", "Results", "the full JSON document of the last run", True),
    ("App::PropertyBool", "OutOfDate", "Results", "the source changed since these results were computed", True),
    ("App::PropertyFloat", "DeltaI_D", "Results",
     "I_D of these results minus I_D of the ones before (NaN: none before, or not established)", True),
    ("App::PropertyIntegerList", "FacesIntegrated", "Results",
     "BRep faces integrated in the last run; the others came unchanged from the faces' store", True),
    ("App::PropertyString", "SettingsUsed", "Results", "the settings of the last run (to tell a changed "
     "source from changed settings)", True),
    ("App::PropertyString", "PreviousFaceShares", "Results", "each face's share of I_D in the result before "
     "(JSON; the change map)", True),
    ("App::PropertyString", "SourceGeometry", "Results", "digest of the source's geometry at the last run "
     "(GUI: to tell whether it changed since)", True),
    ("App::PropertyFileIncluded", "FieldsFile", "Results", "distributed fields of the last run (.npz)", True),
]
for _m in METRICS:
    PROPERTIES += [
        ("App::PropertyFloat", _m, "Signature", "%s (NaN when not established)" % _m, True),
        ("App::PropertyString", _m + "_Status", "Validity", "validity label of %s" % _m, True),
        ("App::PropertyBool", _m + "_Established", "Validity", "True when %s is an established value" % _m, True),
        ("App::PropertyString", _m + "_Reason", "Validity", "reason for the status of %s" % _m, True),
    ]
del _m

HIDDEN = ("ResultJSON", "FieldsFile", "SettingsUsed", "SourceGeometry", "PreviousFaceShares")
#: Set by the GUI (gui.live_update): start(obj) reassesses obj in the background; None in
#: console mode, where a recompute assesses at once.
BACKGROUND = None


def add_properties(obj):
    """Add the properties that obj lacks (new objects and older saved documents)."""
    present = set(obj.PropertiesList)
    for ptype, name, group, tip, output in PROPERTIES:
        if name in present:
            continue
        obj.addProperty(ptype, name, group, tip)
        if output:
            obj.setPropertyStatus(name, "Output")
            obj.setEditorMode(name, 2 if name in HIDDEN else 1)
        if name == "LrefMode":
            obj.LrefMode = LREF_MODES
        if name in QUADRATURE_DEFAULTS:  # a document saved without it: the value it was run with
            if name == "QuadratureProtocol":
                obj.QuadratureProtocol = list(PROTOCOLS)
            setattr(obj, name, QUADRATURE_DEFAULTS[name])
        if name == "Status":
            obj.Status = STATUS_NOT_COMPUTED
        if ptype == "App::PropertyFloat" and (name in METRICS or output):
            setattr(obj, name, float("nan"))


def _flatten(text):
    return " ".join(str(text).split())


class HullProdAnalysis:
    """Proxy of the analysis object. Transient: the last Assessment, a progress callable."""

    Type = TYPE

    def __init__(self, obj):
        self.Type = TYPE
        self.assessment = None
        self.progress = None
        self.pending = None
        self._fields_cache = (None, None)
        obj.Proxy = self
        add_properties(obj)

    # -- persistence (0.20 pickles with __getstate__, 0.21+/1.0 call dumps/loads) ---------------
    def __getstate__(self):
        return {"Type": TYPE, "version": STATE_VERSION}

    def __setstate__(self, state):
        self.Type = (state or {}).get("Type", TYPE)
        self.assessment = None
        self.progress = None
        self.pending = None
        self._fields_cache = (None, None)
        return None

    def dumps(self):
        return self.__getstate__()

    def loads(self, state):
        return self.__setstate__(state)

    def onDocumentRestored(self, obj):
        self.__setstate__(self.__getstate__())
        add_properties(obj)
        restore_floats_from_json(obj)

    # -- recompute --------------------------------------------------------------------------
    def execute(self, obj):
        pending, self.pending = getattr(self, "pending", None), None
        if pending is not None:  # computed for these settings by an assessment process
            assessment, seconds = pending
            self.assessment = assessment
            store_results(obj, assessment, seconds)
            return
        state = source_state(obj) if self.progress is None else None
        if state == "same":  # in the GUI, nothing the results depend on has changed
            if obj.OutOfDate:  # the source was changed back
                obj.OutOfDate, obj.Status = False, STATUS_OK
            return
        if state == "changed":
            # the source was edited, the settings were not: in the GUI the results are marked
            # out of date, or (AutoUpdate) reassessed in the background; never blocking here
            obj.OutOfDate = True
            if obj.AutoUpdate and BACKGROUND is not None:
                obj.Status = "updating: the source changed; reassessing it in the background"
                try:
                    BACKGROUND(obj)
                except InputError as exc:  # a source that cannot be assessed now (no faces): said, kept
                    obj.Status = "error: %s (the results shown are from before)" % _flatten(exc)
                    import FreeCAD
                    FreeCAD.Console.PrintError("HullProd: update of %s: %s\n" % (obj.Label, obj.Status))
            else:
                obj.Status = ("out of date: the source changed after these results (Analyze again, "
                              "or set AutoUpdate)")
            return
        progress = self.progress or RunProgress("HullProd: %s" % obj.Label)
        try:
            assessment, seconds = run_assessment(obj, progress)
        except Cancelled as exc:
            # not an error of the document: the previous results stay, the status says so
            obj.Status = "cancelled: %s (results shown are from the previous run, if any)" % _flatten(exc)
            import FreeCAD
            FreeCAD.Console.PrintWarning("HullProd: %s: %s\n" % (obj.Label, obj.Status))
            return
        except Exception as exc:
            obj.Status = "error: %s" % _flatten(exc)
            import FreeCAD
            FreeCAD.Console.PrintError("HullProd: analysis %s failed: %s\n" % (obj.Label, _flatten(exc)))
            raise
        finally:
            progress.stop()
        self.assessment = assessment
        store_results(obj, assessment, seconds)

    def onChanged(self, obj, prop):
        pass


def settings_used(obj):
    """The settings an analysis runs with, as text (compared with SettingsUsed)."""
    rep = "mesh" if obj.Source is not None and not hasattr(obj.Source, "Shape") else "brep"
    return json.dumps({"options": assessment_options(obj, rep), "faces": list(obj.Faces),
                       "skip_planar": bool(getattr(obj, "SkipPlanarFaces", False))}, sort_keys=True)


def source_geometry(source):
    """Digest of a source's geometry, not of how FreeCAD stores it (an identity placement
    stored or not): of each face's record (brep.face_keys.geometry_digest) or, for a face
    the records do not describe, of its surface type, OpenCascade's values at the
    cross-check points, parameter range, vertices and area; of a mesh, its placed vertices
    and triangles."""
    from ..core.exact_keys import digest
    if not hasattr(source, "Shape"):
        from .assessment_process import object_record
        return object_record(source)["sha256"]
    from ..brep.face_keys import geometry_digest
    from ..brep.reading.occ_records import occ_reference
    out = []
    for face in source.Shape.Faces:
        g = geometry_digest(face)
        if g is None or face.Surface.__class__.__name__ not in ("BSplineSurface", "BezierSurface"):
            g = digest([type(face.Surface).__name__, occ_reference(face), [float(x) for x in face.ParameterRange],
                        [[float(c) for c in v.Point] for v in face.Vertexes], float(face.Area)])
        out.append(g)
    return digest(out)


def source_state(obj):
    """In the GUI, for an analysis with results of its current settings: "same" when its
    source's geometry is as it was (its digest, InputSha256), "changed" when not; None
    otherwise (no GUI, no results, other settings: the recompute assesses)."""
    import FreeCAD
    if not FreeCAD.GuiUp or not (obj.Status == STATUS_OK or obj.Status.startswith(("out of date", "updating"))):
        return None
    if not obj.ResultJSON or not obj.SourceGeometry or obj.SettingsUsed != settings_used(obj) or obj.Source is None:
        return None
    try:
        same = source_geometry(obj.Source) == obj.SourceGeometry
    except Exception:  # a source OpenCascade cannot describe now: the assessment says why
        return None
    if same and obj.Status.startswith("updating"):  # changed back while an update runs: it goes on
        return "changed"
    return "same" if same else "changed"


def assessed_faces(obj):
    """(faces to assess or None for all, planar faces left out) of obj's settings."""
    faces = list(obj.Faces) or None
    if not getattr(obj, "SkipPlanarFaces", False) or not hasattr(obj.Source, "Shape"):
        return faces, []
    from .planar import planar_faces
    planar = planar_faces(obj.Source.Shape, faces)
    chosen = [f for f in (faces or range(1, len(obj.Source.Shape.Faces) + 1)) if f not in planar]
    if not chosen:
        raise InputError("every face of %s is planar: nothing is left to assess without planar faces"
                         % obj.Source.Label)
    return chosen, planar


def assessment_options(obj, rep):
    """api.assess keyword arguments of obj's settings (no source, no progress)."""
    kw = {"lref": obj.LrefExplicit if obj.LrefMode == "explicit" else None,
          "h_f": float(obj.Hf), "k_f": float(obj.Kf)}
    if rep == "brep":
        kw.update(order=int(obj.QuadratureOrder), rtol=float(obj.QuadratureRtol),
                  max_depth=int(obj.QuadratureMaxDepth), protocol=str(obj.QuadratureProtocol),
                  point_budget=int(obj.QuadraturePointBudget), depth_limit=int(obj.QuadratureDepthLimit))
    return kw


def run_assessment(obj, progress):
    """Assess obj.Source with obj's parameters. Returns (Assessment, seconds).

    With the GUI up the assessment runs in an assessment process (app.worker, the command
    line's code and speed; the GUI's own process only waits); in console mode here.
    """
    from .. import api
    src = obj.Source
    if src is None:
        raise InputError("the analysis %s has no source: set its Source to a Part or Mesh object" % obj.Label)
    rep = api.representation_of(src)
    if rep != "brep" and list(obj.Faces):
        raise InputError("Faces selects BRep faces, but the source %s is a triangle mesh: clear Faces"
                         % src.Label)
    faces, planar = assessed_faces(obj) if rep == "brep" else (None, [])
    kw = assessment_options(obj, rep)
    t0 = time.perf_counter()
    progress(0.0, "assessing %s (%s)" % (src.Label, rep))
    import FreeCAD
    from .assessment_process import describe_object_input, object_record, run_in_process
    if FreeCAD.GuiUp:
        assessment = run_in_process(src, faces, kw, progress)
    else:
        if rep == "brep":
            kw["faces"] = faces
        assessment = describe_object_input(api.assess(src, progress=progress, **kw), object_record(src))
    record_planar(assessment, planar)
    return assessment, time.perf_counter() - t0


def record_planar(assessment, planar):
    """Note in the input record the planar faces left out (SkipPlanarFaces)."""
    if planar:
        assessment.input["planar_faces_left_out"] = list(planar)
        assessment.warnings.append("planar faces left out of the assessment: %s"
                                   % ", ".join("Face%d" % f for f in planar))
    return assessment


def _num(x):
    return float("nan") if x is None else float(x)


def store_results(obj, a, seconds=0.0):
    """Copy an Assessment into obj's output properties (the JSON document included), with
    the change of I_D against the results before and the faces integrated anew."""
    doc = a.to_dict()
    before = obj.I_D if obj.ResultJSON else float("nan")
    obj.PreviousFaceShares = json.dumps(face_shares(json.loads(obj.ResultJSON))) if obj.ResultJSON else ""
    new = _num(a.validity["I_D"].value)
    obj.DeltaI_D = new - before if math.isfinite(before) and math.isfinite(new) else float("nan")
    cache = a.provenance.get("cache") or {}
    stored = set(cache.get("faces_from_store") or [])
    obj.FacesIntegrated = [int(r["face"]) for r in (a.provenance.get("faces") or [])  # not those left out
                           if isinstance(r, dict) and "face" in r and r["face"] not in stored
                           and r.get("evaluation") is not None]
    obj.OutOfDate = False
    rl = a.reference_length
    obj.Representation = str(a.input.get("representation") or "")
    obj.Backend = str(a.provenance.get("backend") or obj.Representation)
    obj.LrefUsed = float(rl.value)
    obj.LrefAutomatic = _num(rl.automatic_value)
    obj.LrefUsedMode = str(rl.mode)
    obj.LrefMethod = str(rl.method)
    obj.LrefWarning = str(rl.warning or "")
    obj.TauH = float(a.thresholds.tau_H)
    obj.TauK = float(a.thresholds.tau_K)
    obj.RepresentedArea = _num(a.integrals.represented_area)
    obj.ValidArea = _num(a.integrals.valid_area)
    obj.FacesUsed = [int(f) for f in (a.input.get("faces_used") or [])]
    obj.InputSha256 = str(a.input.get("sha256") or "")
    units = a.provenance.get("units") or {}
    obj.Units = str(units.get("working_unit", units) if isinstance(units, dict) else units) if units else ""
    obj.Warnings = [str(w) for w in a.warnings]
    obj.ComputeSeconds = float(seconds)
    for m in METRICS:
        rec = a.validity[m]
        setattr(obj, m, _num(rec.value))
        setattr(obj, m + "_Status", rec.status.value)
        setattr(obj, m + "_Established", bool(rec.established))
        setattr(obj, m + "_Reason", str(rec.reason or ""))
    obj.ResultJSON = json.dumps(doc, indent=1, allow_nan=False)
    if a.fields is not None:
        from .fields_store import save_fields
        folder = tempfile.mkdtemp(prefix="hullprod_")
        try:
            obj.FieldsFile = save_fields(a.fields, os.path.join(folder, "fields.npz"))
        finally:
            shutil.rmtree(folder, ignore_errors=True)
    obj.SettingsUsed = settings_used(obj)
    import FreeCAD
    if FreeCAD.GuiUp and obj.Source is not None:
        try:
            obj.SourceGeometry = source_geometry(obj.Source)
        except Exception:  # a source OpenCascade cannot describe: every recompute assesses it
            obj.SourceGeometry = ""
    obj.Status = STATUS_OK


def face_shares(doc):
    """{face number (str): its share of I_D, its face-level I_D times its area share, or None}
    of a result document (BRep; a mesh has none)."""
    out = {}
    for r in (doc.get("provenance") or {}).get("faces") or []:
        if isinstance(r, dict) and "face" in r:
            i_d, share = r.get("I_D"), r.get("area_share")
            out[str(r["face"])] = i_d * share if isinstance(i_d, (int, float)) and isinstance(share, (int, float)) \
                else None
    return out


def face_share_changes(obj):
    """{face: change of its share of I_D against the result before, or None where it is not
    in both} ({} without a result before)."""
    if not obj.PreviousFaceShares or not obj.ResultJSON:
        return {}
    before, now = json.loads(obj.PreviousFaceShares), face_shares(json.loads(obj.ResultJSON))
    return {int(f): (v - before[f] if v is not None and before.get(f) is not None else None) for f, v in now.items()}


#: Float outputs restored at full precision from the JSON document after a reload
#: (FreeCAD writes float properties with 16 decimals, not 16 significant digits).
_JSON_FLOATS = {
    "LrefUsed": ("reference_length", "value"),
    "LrefAutomatic": ("reference_length", "automatic_value"),
    "TauH": ("thresholds", "tau_H"),
    "TauK": ("thresholds", "tau_K"),
    "RepresentedArea": ("integrals", "represented_area"),
    "ValidArea": ("integrals", "valid_area"),
}


def restore_floats_from_json(obj):
    """Reset the float outputs from ResultJSON, which keeps every digit."""
    if not obj.ResultJSON:
        return
    try:
        doc = json.loads(obj.ResultJSON)
        for name, (section, key) in _JSON_FLOATS.items():
            setattr(obj, name, _num(doc[section][key]))
        for m in METRICS:
            setattr(obj, m, _num(doc["validity"][m]["value"]))
    except (ValueError, KeyError, TypeError):  # an older or damaged document keeps its values
        pass


# -- queries ---------------------------------------------------------------------------------
def length_unit_label(obj):
    """The analysis's length unit in words: 'mm' for CAD files and FreeCAD shapes (FreeCAD
    works in millimetres), the recorded unit otherwise, 'mesh units' for a mesh that has none."""
    unit = str(getattr(obj, "Units", "") or "")
    if unit == "mm" or "FreeCAD: mm" in unit:
        return "mm"
    if unit:
        return unit
    return "mesh units" if getattr(obj, "Representation", "") == "mesh" else "model units"


def is_analysis(obj):
    """True for a HullProdAnalysis document object."""
    proxy = getattr(obj, "Proxy", None)
    return getattr(proxy, "Type", None) == TYPE or (
        obj is not None and "ResultJSON" in getattr(obj, "PropertiesList", ()) and "Source" in obj.PropertiesList)


def result_document(obj):
    """The JSON document of the last run as a dict (InputError when never computed)."""
    if not obj.ResultJSON:
        raise InputError("the analysis %s has no results yet (status: %s)" % (obj.Label, obj.Status))
    return json.loads(obj.ResultJSON)


def analysis_fields(obj):
    """DistributedFields of the last run (cached per stored file), or None."""
    path = obj.FieldsFile
    if not path or not os.path.isfile(path):
        return None
    proxy = getattr(obj, "Proxy", None)
    cache = getattr(proxy, "_fields_cache", (None, None))
    stamp = (path, os.path.getmtime(path))
    if cache[0] == stamp:
        return cache[1]
    from .fields_store import load_fields
    fields = load_fields(path)
    if proxy is not None:
        proxy._fields_cache = (stamp, fields)
    return fields


def signature_of(obj):
    """metric -> dict(value (float or None), status, established, reason) from properties."""
    out = {}
    for m in METRICS:
        v = getattr(obj, m)
        out[m] = {"value": None if math.isnan(v) else float(v), "status": getattr(obj, m + "_Status"),
                  "established": bool(getattr(obj, m + "_Established")), "reason": getattr(obj, m + "_Reason")}
    return out


# -- creation --------------------------------------------------------------------------------
def _check_source(source):
    if source is None or not hasattr(source, "TypeId") or not hasattr(source, "Document"):
        raise InputError("make_analysis needs a FreeCAD document object (Part or Mesh), got %r" % (source,))
    if not (hasattr(source, "Shape") or hasattr(source, "Mesh")):
        raise InputError("%s (%s) has neither a Part shape nor a mesh" % (source.Label, source.TypeId))


def make_analysis(source, faces=None, lref=None, doc=None, h_f=None, k_f=None, order=None, rtol=None,
                  max_depth=None, protocol=None, point_budget=None, depth_limit=None, label=None, recompute=True, progress=None, skip_planar=False,
                  assessment=None):
    """Create a HullProdAnalysis of source and compute it (the macro equivalent of Analyze).

    source: Part or Mesh document object (never modified); faces: 1-based face numbers of
    a Part (None: all); lref: explicit L_ref in the source's units (None: automatic);
    h_f, k_f, order, rtol, max_depth, protocol, point_budget, depth_limit: None takes the
    HullProd preferences (brep.validity.budget.DEFAULT_QUADRATURE). progress:
    optional callable(fraction, message); skip_planar: leave out planar faces;
    assessment: (Assessment, seconds) already computed for exactly these settings (an
    assessment process of the GUI), stored instead of a run. When the run fails or is
    cancelled the new object is removed and the error (InputError, Cancelled, ...) is raised.
    """
    _check_source(source)
    doc = doc or source.Document
    defaults = preferences.analysis_defaults()
    obj = doc.addObject("App::FeaturePython", TYPE)
    HullProdAnalysis(obj)
    obj.Label = label or "HullProd_%s" % source.Label
    obj.Source = source
    if faces:
        faces = sorted(set(int(f) for f in faces))
        if min(faces) < 1:
            doc.removeObject(obj.Name)
            raise InputError("face numbers start at 1 (Face1), got %s" % faces)
    obj.Faces = list(faces or [])
    obj.SkipPlanarFaces = bool(skip_planar)
    if lref is not None:
        obj.LrefMode = "explicit"
        obj.LrefExplicit = float(lref)
    obj.Hf = float(defaults["h_f"] if h_f is None else h_f)
    obj.Kf = float(defaults["k_f"] if k_f is None else k_f)
    obj.QuadratureOrder = int(defaults["order"] if order is None else order)
    obj.QuadratureRtol = float(defaults["rtol"] if rtol is None else rtol)
    obj.QuadratureMaxDepth = int(defaults["max_depth"] if max_depth is None else max_depth)
    protocol = defaults["protocol"] if protocol is None else protocol
    if protocol not in PROTOCOLS:
        doc.removeObject(obj.Name)
        raise InputError("protocol must be one of %s, got %r" % (", ".join(PROTOCOLS), protocol))
    obj.QuadratureProtocol = protocol
    obj.QuadraturePointBudget = int(defaults["point_budget"] if point_budget is None else point_budget)
    obj.QuadratureDepthLimit = int(defaults["depth_limit"] if depth_limit is None else depth_limit)
    attach_view_provider(obj)
    obj.Proxy.pending = assessment
    if recompute or assessment is not None:
        try:
            recompute_analysis(obj, progress)
        except Exception:
            doc.removeObject(obj.Name)
            raise
    return obj


def attach_view_provider(obj):
    """Give obj its colour-map view provider when the GUI is up (nothing in console mode)."""
    import FreeCAD
    if FreeCAD.GuiUp and getattr(obj, "ViewObject", None) is not None:
        from ..gui.view_provider import ViewProviderHullProdAnalysis
        ViewProviderHullProdAnalysis(obj.ViewObject)


class AnalysisFailed(InputError):
    """A recompute of an analysis ended in error (message from the object's Status)."""


def recompute_analysis(obj, progress=None):
    """Recompute obj now (with an optional progress callable); raise when it failed.

    Raises Cancelled when the user cancelled, AnalysisFailed with the reason otherwise.
    """
    proxy = obj.Proxy
    if progress is not None and not isinstance(progress, RunProgress):
        progress = RunProgress("HullProd: %s" % obj.Label, listener=progress)
    proxy.progress = progress
    try:
        obj.touch()
        obj.Document.recompute([obj])
    finally:
        proxy.progress = None
    status = obj.Status
    if status.startswith("cancelled"):
        raise Cancelled(status)
    if status != STATUS_OK:
        raise AnalysisFailed("HullProd analysis of %s: %s" % (
            obj.Source.Label if obj.Source else "?", status if status != STATUS_NOT_COMPUTED else
            "not computed (%s)" % (obj.getStatusString() if hasattr(obj, "getStatusString") else "?")))
    return obj


def analyses_in(doc):
    """All HullProdAnalysis objects of a document."""
    return [o for o in doc.Objects if is_analysis(o)]
