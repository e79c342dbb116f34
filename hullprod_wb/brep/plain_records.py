"""Plain-data records of a BRep file read by OpenCascade, made in a child process.

A BRep file's assessment needs OpenCascade only to read the geometry: its B-spline and
Bezier faces are integrated from poles, knots and weights, their trimmed domains from the
p-curves' data. So a child (reader_process: forked from a clean process, else a fresh
interpreter) reads the file with FreeCAD, turns every face into plain numbers (lists,
tuples, arrays of doubles: see face_record), makes the tessellations and the OpenCascade
values the records need, and sends them to the parent through a pipe, while the parent
loads numpy and the numerical modules. A face this module does not describe (another
surface type, a planar face, a p-curve of another type or none) travels as OpenCascade's
binary BRep data (faces_to_bytes) and is rebuilt in the process that integrates it, which
then loads FreeCAD (recorded_shape); either way the fields and domains are built from the
same numbers as from the faces read in that process.

The child sends three frames: the face records (with OpenCascade's values at the
cross-check points and the edges' vertices, and the faces sent as data) and the file's
description; the nodes of the automatic-L_ref tessellation (and the described faces as
data too, for a trimmed domain that needs OpenCascade); then, at the lowest priority, what
is only needed at the end (provenance with OpenCascade's face areas, the display
tessellation). The records come first, so that the parent sets the faces up while the
tessellation runs (ReadInChild.ready tells it whether the next frame is there). A child
that dies (an exit or a signal in OpenCascade) makes the parent raise ReaderDied.

Nothing here imports numpy: the reading side never loads it.
"""
import os
import time
from array import array

#: Cross-check points per face (backend.cross_check_occ compares at the same points).
CROSS_CHECK_POINTS = 7
#: Samples of each p-curve at which its conversion is checked against OpenCascade.
PCURVE_CHECK_SAMPLES = 5
#: Default display deflection as a fraction of the shape's bounding-box diagonal.
DISPLAY_DEFLECTION = 5e-3


def unwrap_surface(surface):
    """Strip Part.RectangularTrimmedSurface wrappers (same parameterisation as the basis)."""
    while type(surface).__name__ == "RectangularTrimmedSurface":
        surface = surface.BasisSurface
    return surface


def orientation_sign_of(face):
    """+1 for a Forward (or Internal/External) face, -1 for a Reversed one.

    Only REVERSED flips the normal in OpenCascade's topology (BRepAdaptor, BRepLProp).
    """
    return -1 if getattr(face, "Orientation", "Forward") == "Reversed" else 1


def xy(p):
    """(x, y) floats of a FreeCAD 2-D point or vector."""
    return (float(p.x), float(p.y))


def linspace(a, b, n):
    """n equally spaced values from a to b, as numpy.linspace computes them (i * step + a,
    the last one b)."""
    step = (b - a) / (n - 1)
    return [float(i) * step + a for i in range(n - 1)] + [b]


def nurbs_record(surface):
    """Degrees, flat knots, poles (nested lists of (x, y, z)), weights and the domain of a
    Part.BSplineSurface or Part.BezierSurface, as nurbs.NurbsSurfaceData takes them (a
    periodic direction unperiodised on a copy, which keeps the parameterisation); None for
    other types."""
    name = type(surface).__name__

    def poles_weights(s):
        poles = [[(pt.x, pt.y, pt.z) for pt in row] for row in s.getPoles()]
        weights = [list(r) for r in s.getWeights()] if s.isURational() or s.isVRational() else None
        return poles, weights

    if name == "BezierSurface":
        p, q = surface.UDegree, surface.VDegree
        poles, weights = poles_weights(surface)
        return {"udegree": p, "vdegree": q, "uknots": [0.0] * (p + 1) + [1.0] * (p + 1),
                "vknots": [0.0] * (q + 1) + [1.0] * (q + 1), "poles": poles, "weights": weights}
    if name != "BSplineSurface":
        return None
    u0, u1, v0, v1 = surface.bounds()
    uper, vper = surface.isUPeriodic(), surface.isVPeriodic()
    rec = {"uknots_distinct": list(surface.getUKnots()), "umults": list(surface.getUMultiplicities()),
           "vknots_distinct": list(surface.getVKnots()), "vmults": list(surface.getVMultiplicities())}
    work = surface
    if uper or vper:
        work = surface.copy()  # never modify the caller's geometry
        if uper:
            work.setUNotPeriodic()
        if vper:
            work.setVNotPeriodic()
    poles, weights = poles_weights(work)
    flat = [[float(k) for k, m in zip(knots, mults) for _ in range(m)]
            for knots, mults in ((work.getUKnots(), work.getUMultiplicities()),
                                 (work.getVKnots(), work.getVMultiplicities()))]
    # the domain of the un-periodised copy is its FirstKnotIndex..LastKnotIndex knots
    rec.update(udegree=work.UDegree, vdegree=work.VDegree, uknots=flat[0], vknots=flat[1],
               poles=poles, weights=weights, urange=(float(u0), float(u1)), vrange=(float(v0), float(v1)),
               uperiod=float(u1 - u0) if uper else None, vperiod=float(v1 - v0) if vper else None)
    return rec


def pcurve_record(geom, s0, s1):
    """Plain description of a Geom2d curve on [s0, s1] (kind "line", "conic" or "nurbs",
    see trimmed_domain.curve_from_record) with OpenCascade's points at PCURVE_CHECK_SAMPLES
    parameters to check the conversion against; None for other curve types."""
    kind = type(geom).__name__
    s0, s1 = float(s0), float(s1)
    if kind in ("Line2d", "Line2dSegment"):
        rec = {"kind": "line", "p0": xy(geom.value(s0)), "p1": xy(geom.value(s1))}
    elif kind in ("Circle2d", "ArcOfCircle2d", "Ellipse2d", "ArcOfEllipse2d"):
        radii = ((geom.Radius, geom.Radius) if "Circle" in kind else (geom.MajorRadius, geom.MinorRadius))
        rec = {"kind": "conic", "center": xy(geom.Location), "xaxis": xy(geom.XAxis),
               "yaxis": xy(geom.YAxis), "rx": float(radii[0]), "ry": float(radii[1])}
    elif kind in ("BSplineCurve2d", "BezierCurve2d"):
        g = geom.copy()
        if kind == "BSplineCurve2d" and g.isPeriodic():
            g.setNotPeriodic()
        knots = (list(g.KnotSequence) if kind == "BSplineCurve2d"
                 else [0.0] * (g.Degree + 1) + [1.0] * (g.Degree + 1))
        rec = {"kind": "nurbs", "degree": g.Degree, "knots": knots, "poles": [xy(p) for p in g.getPoles()],
               "weights": list(g.getWeights())}
    else:
        return None
    s = linspace(s0, s1, PCURVE_CHECK_SAMPLES)
    rec.update(s0=s0, s1=s1, check_s=s, check_uv=[xy(geom.value(x)) for x in s])
    return rec


def face_pcurves(face, wire_edges=None):
    """(edge, face.curveOnSurface(edge)) of every edge of every wire of face, in the order
    of the trimmed domain's curves: each wire's children (wire_edges: those lists, when
    given), a seam edge with both of its occurrences (the two p-curves). FreeCAD 0.20 lists
    both occurrences among a wire's children, FreeCAD 1.x one; a seam listed once is taken
    a second time, reversed (the other p-curve), after its wire's other children, which is
    where 0.20 lists it."""
    wires = wire_edges if wire_edges is not None else \
        [[e for e in wire.childShapes() if e.ShapeType == "Edge"] for wire in face.Wires]
    listed = [e for edges in wires for e in edges]
    out = []
    for edges in wires:
        second = [e.reversed() for e in edges if _is_seam(e, face) and
                  sum(1 for other in listed if other.isSame(e)) == 1]
        out.extend((edge, face.curveOnSurface(edge)) for edge in edges + second)
    return out


def _is_seam(edge, face):
    """Whether edge is a seam of face (two p-curves on it)."""
    try:
        return bool(edge.isSeam(face))
    except Exception:  # an edge OpenCascade cannot place on the face: not a seam it knows
        return False


def edge_vertices(edges):
    """Topological vertices at the ends of edges (as p-curves run: an edge's first vertex
    at its p-curve's start, its last at its end): per edge the pair of indices into the
    list of distinct vertices, and that list of (point (x, y, z), tolerance)."""
    found, out = [], []
    for edge in edges:
        pair = []
        for vertex in (edge.firstVertex(False), edge.lastVertex(False)):
            for k, (other, _) in enumerate(found):
                if other.isSame(vertex):
                    break
            else:
                k = len(found)
                p = vertex.Point
                found.append((vertex, ((p.x, p.y, p.z), float(vertex.Tolerance))))
            pair.append(k)
        out.append(tuple(pair))
    return out, [v for _, v in found]


def patch_count(face):
    """Knot-span patches of a face's surface (1 for other surface types): the order in which
    faces are handed to worker processes, largest first."""
    try:
        surf = face.Surface
        return max(1, (len(surf.getUKnots()) - 1) * (len(surf.getVKnots()) - 1))
    except Exception:  # not a B-spline surface, or no surface
        return 1


def cross_check_params(parameter_range, n=CROSS_CHECK_POINTS):
    """(u, v) lists of the cross-check points: a diagonal of the face's parameter range."""
    u0, u1, v0, v1 = (float(x) for x in parameter_range)
    t = [(i + 0.5) / n for i in range(n)]
    return [u0 + (u1 - u0) * x for x in t], [v0 + (v1 - v0) * x for x in reversed(t)]


def occ_reference(face, n=CROSS_CHECK_POINTS):
    """OpenCascade's S_u, S_v, Gaussian and mean curvature (the latter for the face's surface
    as it is, before the face's orientation) at the cross-check points: a list of
    (su, sv, K, H) tuples, None where OpenCascade gives none (a degenerate point)."""
    surf = face.Surface
    out = []
    for a, b in zip(*cross_check_params(face.ParameterRange, n)):
        try:
            du, dv = surf.getDN(a, b, 1, 0), surf.getDN(a, b, 0, 1)
            out.append(((du.x, du.y, du.z), (dv.x, dv.y, dv.z),
                        float(surf.curvature(a, b, "Gauss")), float(surf.curvature(a, b, "Mean"))))
        except Exception:  # undefined curvature at a degenerate point: nothing to compare
            out.append(None)
    return out


def face_record(face):
    """(record, None) of a face whose surface is a B-spline or Bezier surface and whose
    p-curves this module describes, else (None, the reason). The record: surface_type,
    nurbs (nurbs_record), orientation_sign, parameter_range, pcurves (pcurve_record each),
    end_vertices and vertices (edge_vertices), patch_count, occ_reference. OpenCascade's
    area of the face (slow: tens of milliseconds on a hull's faces) is not part of it; the
    provenance takes it last."""
    surface = unwrap_surface(face.Surface)
    name = type(surface).__name__
    nurbs = nurbs_record(surface)
    if nurbs is None:
        return None, "a %s surface" % name
    pcurves, edges = [], []
    for edge, pc in face_pcurves(face):
        rec = None if pc is None else pcurve_record(*pc)
        if rec is None:
            return None, ("an edge without a p-curve" if pc is None else
                          "a p-curve of type %s" % type(pc[0]).__name__)
        pcurves.append(rec)
        edges.append(edge)
    end_vertices, vertices = edge_vertices(edges)
    return {"surface_type": type(face.Surface).__name__, "kind": "bspline" if name == "BSplineSurface" else "bezier",
            "nurbs": nurbs, "orientation_sign": orientation_sign_of(face),
            "parameter_range": tuple(float(x) for x in face.ParameterRange), "pcurves": pcurves,
            "patch_count": patch_count(face), "occ_reference": occ_reference(face),
            "end_vertices": end_vertices, "vertices": vertices}, None


# -- the child -------------------------------------------------------------------------------


def part_record(face, why):
    """The record of a face sent as OpenCascade's own data (faces_to_bytes) instead of plain
    numbers (another surface type, a planar face, a p-curve of another type or none, or a
    face face_record could not describe): surface_type, kind "part", reason, patch_count and
    occ_reference; the face itself travels in the frame's part_faces."""
    try:
        surface_type = type(face.Surface).__name__
    except Exception:  # no surface OpenCascade can give: the parent's set-up says so
        surface_type = "unknown"
    try:
        reference = occ_reference(face)
    except Exception:  # no parameter range: nothing to compare
        reference = [None] * CROSS_CHECK_POINTS
    return {"surface_type": surface_type, "kind": "part", "reason": why, "patch_count": patch_count(face),
            "occ_reference": reference}


def faces_to_bytes(faces):
    """Part.Face list -> OpenCascade's binary BRep data of their compound (loading.
    shape_to_bytes: the faces' orientations and locations as they are)."""
    import Part
    from .loading import shape_to_bytes
    return shape_to_bytes(Part.Compound(list(faces)))


def faces_from_bytes(data):
    """The Part.Face list faces_to_bytes wrote, in its order (FreeCAD is loaded here for it)."""
    from .loading import shape_from_bytes
    return list(shape_from_bytes(data).Faces)


def record_frames(path, faces, with_fields, display_deflection):
    """In the reading process (reader_process): read path with FreeCAD and yield the three
    frames of its records (see the module doc)."""
    from ..freecad_env import import_freecad
    from .loading import load_brep
    from .reader_process import STAGE
    import_freecad()
    t = time.perf_counter()
    inp = load_brep(path, faces, here=True)
    seconds = time.perf_counter() - t
    yield {STAGE: "describing the faces"}
    for frame in _frames(inp, with_fields, display_deflection, seconds):
        yield frame


def _frames(inp, with_fields, display_deflection, read_seconds):
    """The three frames of the records of a loaded BRepInput (see the module doc), each
    with what comes after it (reader_process.STAGE)."""
    from ..freecad_env import versions
    from .lref_samples import SAMPLE_DEFLECTION, tessellate_faces
    from .provenance import shape_boxes
    from .reader_process import STAGE
    boxes = shape_boxes(inp.shape, inp.faces)  # before any tessellation, as when read here
    size = float(boxes[0].DiagonalLength)
    faces, as_data, described = [], [], []
    for number, face in inp.faces:
        try:
            rec, why = face_record(face)
        except Exception as exc:  # OpenCascade cannot give what the record needs: the face as data
            rec, why = None, "an OpenCascade error (%s)" % " ".join(str(exc).split())
        if rec is None:
            rec = part_record(face, why)
            rec["part"] = len(as_data)
            as_data.append(face)
        else:
            rec["part"] = len(described)
            described.append(face)
        rec["number"] = number
        faces.append(rec)
    # the records first: the parent sets the faces up while the tessellation runs here
    yield {"info": inp.info, "units": inp.units, "faces": faces, "size": size, "versions": versions(),
           "read_seconds": read_seconds, "part_faces": faces_to_bytes(as_data) if as_data else None,
           STAGE: "tessellating the faces"}
    t = time.perf_counter()
    pts, tris = tessellate_faces([f for _, f in inp.faces], SAMPLE_DEFLECTION * size)
    # with the described faces as data too, for a trimmed domain that needs OpenCascade
    # (recorded_shape.FaceRecord.part_face): here before any worker process starts
    yield {"lref_points": pts, "lref_triangles": tris, "seconds": time.perf_counter() - t,
           "described_faces": faces_to_bytes(described) if described else None,
           STAGE: "computing the faces' areas and display tessellation"}
    # the rest is needed only at the end: give the CPUs to the integration meanwhile
    try:
        os.nice(19)
    except OSError:
        pass
    from .provenance import shape_provenance
    late = {}
    if with_fields:
        deflection = display_deflection or DISPLAY_DEFLECTION * size
        late["display"] = [display_mesh(f, deflection) for _, f in inp.faces]
        late["display_deflection"] = deflection
    late["provenance"] = shape_provenance(inp.shape, inp.faces, None, boxes)
    yield late


def display_mesh(face, deflection):
    """OpenCascade's display tessellation of face: its nodes (flat x, y, z doubles), its
    triangles (flat indices) and the (u, v) nodes of its triangulation (flat u, v); all
    three empty for a face OpenCascade gives no triangulation (a face of zero area)."""
    pts, tris = face.tessellate(deflection)
    p, t, uv = array("d"), array("q"), array("d")
    if not tris:
        return p, t, uv
    for q in pts:
        p.extend((q.x, q.y, q.z))
    for tri in tris:
        t.extend(tri)
    for q in face.getUVNodes():
        uv.extend((float(q[0]), float(q[1])))
    return p, t, uv


def reads_in_child(jobs=None):
    """Whether a BRep file named by its path is read by a ReadInChild (api.assess;
    cli.early_reading starts it earlier): always, whatever jobs (kept for callers that ask)."""
    return True


class ReadInChild:
    """The records of a BRep file, read by a child started now (reader_process: forked from
    a clean process, else a fresh interpreter; see the module doc).

    frame(k) returns frame k (0: faces, 1: L_ref tessellation, 2: the rest) as the child
    sent it. An InputError of the child (an unreadable file, a bad face number) is raised
    here with its message; a child that ends before sending frame k raises ReaderDied (an
    InputError) naming the file and what OpenCascade was doing.
    """

    FRAMES = 3

    def __init__(self, path, faces=None, with_fields=True, display_deflection=None):
        from .reader_process import ReaderProcess
        self.path, self.faces = path, faces
        self.with_fields, self.display_deflection = with_fields, display_deflection
        self._frames = []
        self._child = ReaderProcess(path, (__name__, "record_frames"),
                                    (path, faces, with_fields, display_deflection))

    def ready(self, k):
        """Whether frame(k) would return without waiting for the child (or the child has
        ended): frame k has arrived, or the next frame has begun to arrive."""
        if len(self._frames) > k:
            return True
        if len(self._frames) < k:
            return False
        return self._child.ready()

    def frame(self, k):
        while len(self._frames) <= k:
            self._frames.append(self._child.receive(last=len(self._frames) == self.FRAMES - 1))
        return self._frames[k]

    def close(self):
        """Stop (if still running) and reap the child."""
        self._child.close()
