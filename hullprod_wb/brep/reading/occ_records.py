"""OpenCascade's geometry of a face as plain numbers: lists, tuples and arrays of doubles.

A B-spline or Bezier face is integrated from its poles, knots and weights and its trimmed
domain from its p-curves' data, so face_record describes the face by those numbers
(nurbs_record, pcurve_record, edge_vertices) with OpenCascade's own values at the
cross-check points (occ_reference); display_mesh gives OpenCascade's display tessellation
as flat arrays. The numerical modules build their evaluators from these records, and the
reading process (record_reader) sends them to the process that integrates.

Nothing here imports numpy: the reading side never loads it.
"""
from array import array
from dataclasses import dataclass
from typing import Optional

#: Cross-check points per face (cross_checks.cross_check_occ compares at the same points).
CROSS_CHECK_POINTS = 7
#: Samples of each p-curve at which its conversion is checked against OpenCascade.
PCURVE_CHECK_SAMPLES = 5
#: Default display deflection as a fraction of the shape's bounding-box diagonal.
DISPLAY_DEFLECTION = 5e-3


@dataclass(frozen=True)
class FaceData:
    """The record of one face as the reading process sends it; one set of fields for every
    face. number: the face's 1-based number in the shape; surface_type: OpenCascade's name of
    its surface; kind: "bspline" or "bezier" (described by numbers) or "part" (sent as
    OpenCascade's data, loading.faces_to_bytes, for the reason given); part: its index among
    the faces sent as data ("part") or among the described faces (which also travel as data,
    for a trimmed domain that needs OpenCascade); patch_count and occ_reference (OpenCascade's
    values at the cross-check points); and for a described face nurbs (nurbs_record),
    orientation_sign, parameter_range, pcurves (pcurve_record each), end_vertices and
    vertices (edge_vertices); for a face sent as data, data_digest (the SHA-256 of its data
    alone: its key in the result store, brep.face_keys)."""

    number: int
    surface_type: str
    kind: str
    part: int
    patch_count: int
    occ_reference: list
    reason: Optional[str] = None
    nurbs: Optional[dict] = None
    orientation_sign: Optional[int] = None
    parameter_range: Optional[tuple] = None
    pcurves: Optional[list] = None
    end_vertices: Optional[list] = None
    vertices: Optional[list] = None
    data_digest: Optional[str] = None

    @property
    def as_data(self):
        """Whether the face travels as OpenCascade's data instead of numbers."""
        return self.kind == "part"


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
    see pcurves.curve_from_record) with OpenCascade's points at PCURVE_CHECK_SAMPLES
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


def face_record(face, number, part):
    """(FaceData, None) of a face whose surface is a B-spline or Bezier surface and whose
    p-curves this module describes, else (None, the reason); number: the face's number,
    part: its index among the described faces. OpenCascade's area of the face (slow: tens
    of milliseconds on a hull's faces) is not part of it; the provenance takes it last."""
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
    return FaceData(number=number, surface_type=type(face.Surface).__name__,
                    kind="bspline" if name == "BSplineSurface" else "bezier", part=part,
                    patch_count=patch_count(face), occ_reference=occ_reference(face), nurbs=nurbs,
                    orientation_sign=orientation_sign_of(face),
                    parameter_range=tuple(float(x) for x in face.ParameterRange), pcurves=pcurves,
                    end_vertices=end_vertices, vertices=vertices), None


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
