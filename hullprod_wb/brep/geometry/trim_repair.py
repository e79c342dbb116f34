"""Exact repairs of the trim loops of faces read from files (TrimmedDomain.from_face).

A wrong or missing p-curve on a plane becomes the affine image of the edge's 3-D curve
(plane_pcurve, plane_image), and loops left open at a vertex are closed by a parameter
segment whose image stays inside that vertex's tolerance ball (close_gaps: a collapsed
side of the surface, or a gap within the shape's own tolerance).
"""
import numpy as np

from ...core.errors import InputError
from ..reading.occ_records import unwrap_surface
from .pcurves import ConicArc2D, FunctionCurve2D, NurbsCurve2D, curve_from_geom2d

#: OpenCascade's Precision::Confusion (model units): points closer than this coincide.
PRECISION_CONFUSION = 1e-7
#: Points of an edge at which a plane's p-curve is compared with the edge's 3-D curve.
PLANE_CHECK_SAMPLES = 9
#: Points of a closing parameter segment checked against its vertex's tolerance ball.
GAP_SAMPLES = 33


def _xyz(p):
    return (float(p.x), float(p.y), float(p.z))


def plane_frame(face):
    """(O, X, Y) (3,) float each when the face's surface is a plane S(u, v) = O + u X + v Y
    (X, Y orthonormal), else None. Read from S itself: O = S(0, 0), X = S(1, 0) - O,
    Y = S(0, 1) - O (exact, S is affine)."""
    surface = unwrap_surface(face.Surface)
    if type(surface).__name__ != "Plane":
        return None
    o, x, y = (np.array(_xyz(surface.value(u, v))) for u, v in ((0.0, 0.0), (1.0, 0.0), (0.0, 1.0)))
    return o, x - o, y - o


def plane_image(edge, frame):
    """Exact p-curve of a 3-D edge lying in the plane ``frame`` = (O, X, Y).

    The map x -> ((x - O).X, (x - O).Y) is affine and inverts S on the plane, so the image of
    a line is the segment between the images of its ends, of a circle or ellipse
    c + a cos s + b sin s the conic with the images of c, a, b, and of a (rational)
    B-spline or Bezier curve the curve with the images of its poles (same knots and
    weights: NURBS are affine invariant). Other curves, or an image that does not
    reproduce the edge's points to 1e-12 of its size, are mapped point by point
    (:class:`FunctionCurve2D` of Edge.valueAt). Parameter: the edge's own.
    """
    o, X, Y = frame
    L = np.array([X, Y])  # (2, 3)

    def image(points):  # (n, 3) -> (n, 2)
        return (np.asarray(points, dtype=float).reshape(-1, 3) - o) @ L.T

    s0, s1 = (float(x) for x in edge.ParameterRange)
    geom = edge.Curve
    while type(geom).__name__ == "TrimmedCurve":
        geom = geom.BasisCurve
    kind = type(geom).__name__
    curve = None
    if kind in ("Line", "LineSegment"):
        ends = image([_xyz(edge.valueAt(s0)), _xyz(edge.valueAt(s1))])
        curve = NurbsCurve2D.line(ends[0], ends[1], s0, s1)
    elif kind in ("Circle", "Ellipse"):
        rx, ry = ((geom.Radius, geom.Radius) if kind == "Circle"
                  else (geom.MajorRadius, geom.MinorRadius))
        curve = ConicArc2D(image([_xyz(geom.Center)])[0], L @ np.array(_xyz(geom.XAxis)),
                           L @ np.array(_xyz(geom.YAxis)), rx, ry, s0, s1)
    elif kind in ("BSplineCurve", "BezierCurve"):
        g = geom.copy()
        if kind == "BSplineCurve" and g.isPeriodic():
            g.setNotPeriodic()
        poles = image([_xyz(q) for q in g.getPoles()])
        knots = (list(g.KnotSequence) if kind == "BSplineCurve"
                 else [0.0] * (g.Degree + 1) + [1.0] * (g.Degree + 1))
        curve = NurbsCurve2D(g.Degree, knots, poles, list(g.getWeights()), s0, s1)
    s = np.linspace(s0, s1, 5)
    ref = image([_xyz(edge.valueAt(float(x))) for x in s])
    size = max(1.0, float(np.abs(ref).max()))
    if curve is None or np.abs(curve.value(s) - ref).max() > 1e-12 * size:
        def value(t):
            return image([_xyz(edge.valueAt(float(x))) for x in t])

        def derivative(t):
            return np.array([_xyz(edge.derivative1At(float(x))) for x in t]).reshape(-1, 3) @ L.T
        curve = FunctionCurve2D(value, derivative, s0, s1)
    return curve


def plane_pcurve(edge, pcurve, frame):
    """The p-curve of an edge of a planar face, checked against the edge's 3-D curve.

    pcurve: face.curveOnSurface(edge) ((geom2d, s0, s1) or None). Returns (curve, note):
    the stored p-curve and None when S(p-curve) stays within the edge's tolerance of the
    3-D curve at PLANE_CHECK_SAMPLES parameters; otherwise, when the 3-D curve lies in the
    plane within that tolerance, its exact image (:func:`plane_image`) and a note. A
    missing p-curve whose edge leaves the plane raises InputError; a wrong one is kept.
    """
    stored = None if pcurve is None else curve_from_geom2d(*pcurve)
    if edge.Degenerated:
        if stored is None:
            raise InputError("degenerated edge without a p-curve on a plane")
        return stored, None
    o, X, Y = frame
    tol = max(float(edge.Tolerance), PRECISION_CONFUSION)
    s0, s1 = (float(x) for x in edge.ParameterRange)
    try:
        pts = np.array([_xyz(edge.valueAt(float(x)))
                        for x in np.linspace(s0, s1, PLANE_CHECK_SAMPLES)])
        kind = type(edge.Curve).__name__
    except Exception:  # OCC raises its own types: no 3-D curve to compare with
        if stored is None:
            raise InputError("face edge has neither a p-curve nor a 3-D curve") from None
        return stored, None
    deviation = np.inf
    if stored is not None:
        uv = stored.value(np.linspace(stored.s0, stored.s1, PLANE_CHECK_SAMPLES))
        on_plane = o + uv[:, :1] * X + uv[:, 1:] * Y
        deviation = float(np.linalg.norm(on_plane - pts, axis=1).max())
        if deviation <= tol:
            return stored, None
    normal = np.cross(X, Y)
    off_plane = float(np.abs((pts - o) @ normal).max())
    if off_plane > tol:
        if stored is None:
            raise InputError("face edge has no p-curve and its 3-D curve leaves the face's plane "
                             "by %.3g (tolerance %.3g)" % (off_plane, tol))
        return stored, None
    what = ("missing p-curve" if stored is None else
            "p-curve %.3g off its 3-D curve (tolerance %.3g)" % (deviation, tol))
    return plane_image(edge, frame), "plane: %s replaced by the image of the 3-D %s" % (
        what, kind)


def close_gaps(evaluator, end_vertices, vertices, error):
    """Straight parameter segments closing the trim loops at their open ends, exactly.

    evaluator: the face's SurfaceEvaluator; end_vertices: per p-curve the indices into
    vertices of the topological vertices at its start and end (occ_records.edge_vertices);
    vertices: (point (x, y, z), tolerance) of each; error: the :class:`OpenTrimLoops` of the
    p-curves (trimmed_domain.OpenTrimLoops). The open ends are grouped by the topological vertex of their edge (the edge's
    first vertex for a p-curve's start, its last for its end) and paired, nearest first,
    within a vertex. The segment from end p to end q is accepted when its image
    g(t) = S(p + t (q - p)) stays in the vertex's tolerance ball: max |g(t_i) - V| over
    GAP_SAMPLES points plus the chord bound h^2/8 max |g''| (h the sample spacing) is at
    most the vertex tolerance. Exactness: a BRep vertex is the ball |x - V| <= tol_V, and
    the two edges meet there by the shape's own topology; the segment adds no boundary
    outside that ball, so the closed domain is the face the BRep defines, ambiguous only
    inside the ball (area at most about pi tol_V^2 per gap). On a collapsed side of the
    surface (S constant along the segment: a pole, a cone apex) g is the vertex point itself.
    Returns (segments, notes); raises InputError (the error's message and the reason)
    when some open end has no such closure.
    """
    def fail(reason):
        raise InputError("%s; no exact closure: %s" % (error, reason)) from error

    ends = error.ends
    groups = {}  # vertex index -> [end indices], in order of first appearance
    for i in (int(k) for k in error.open_ends):
        groups.setdefault(end_vertices[i // 2][i % 2], []).append(i)
    segments, notes = [], []
    t = np.linspace(0.0, 1.0, GAP_SAMPLES)
    h = t[1] - t[0]
    for vid, idx in groups.items():
        point, vertex_tol = vertices[vid]
        V = np.array(point, dtype=float)
        tol = max(float(vertex_tol), PRECISION_CONFUSION)
        if len(idx) % 2:
            fail("%d open p-curve end(s) at the vertex (%.6g, %.6g, %.6g), none of another "
                 "edge there to join" % ((len(idx),) + tuple(V)))
        idx = list(idx)
        while idx:
            pairs = [(float(np.linalg.norm(ends[a] - ends[b])), a, b)
                     for j, a in enumerate(idx) for b in idx[j + 1:]]
            _, a, b = min(pairs)
            idx.remove(a), idx.remove(b)
            p, q = ends[a], ends[b]
            d = q - p
            uv = p + t[:, None] * d
            S, _, _, Suu, Suv, Svv = evaluator.derivatives(uv[:, 0], uv[:, 1])
            g2 = d[0] ** 2 * Suu + 2.0 * d[0] * d[1] * Suv + d[1] ** 2 * Svv
            dev = float(np.linalg.norm(S - V, axis=1).max())
            bound = dev + h * h / 8.0 * float(np.linalg.norm(g2, axis=1).max())
            if not bound <= tol:
                fail("the parameter segment from (%.6g, %.6g) to (%.6g, %.6g) leaves the vertex "
                     "(%.6g, %.6g, %.6g) by %.3g, more than its tolerance %.3g"
                     % (tuple(p) + tuple(q) + tuple(V) + (bound, tol)))
            segments.append(NurbsCurve2D.line(p, q))
            kind = "collapsed side" if bound <= PRECISION_CONFUSION else "gap"
            notes.append("%s closed at vertex (%.6g, %.6g, %.6g): parameter segment (%.6g, %.6g)-"
                         "(%.6g, %.6g), 3-D deviation %.3g <= vertex tolerance %.3g"
                         % ((kind,) + tuple(V) + tuple(p) + tuple(q) + (bound, tol)))
    return segments, notes

