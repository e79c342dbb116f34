"""Split the faces of a BRep hull into many B-spline pieces of the same shape (bench/brep_scale.py).

Each face's surface, as a B-spline, is cut along a k x k grid of its parameter box
(BSplineSurface.segment keeps the parametrization, so the pieces tile the face exactly). An
untrimmed face gives k^2 untrimmed pieces. A trimmed face is cut in its parameter plane: its
p-curves make a planar face in z = 0 (end points snapped together), the grid cells the trim
boundary passes through are intersected with it by a planar Boolean (fast and robust in
OpenCascade, unlike Booleans of coincident curved faces), the cells inside are kept whole
and those outside dropped; a cut cell becomes a face on its segment bounded by the cut's
curves as p-curves. A face where that fails is split by the cells' centres instead
(Face.isPartOfDomain; not an exact tiling) and counted. Needs FreeCAD imported first.
"""
import math

import numpy as np
import FreeCAD
import Part

V = FreeCAD.Vector
V2 = FreeCAD.Base.Vector2d


def bspline_face(face):
    """(face whose surface is a BSplineSurface, its surface)."""
    if not isinstance(face.Surface, Part.BSplineSurface):
        face = face.toNurbs().Faces[0]
    return face, face.Surface


def _curve3d(c2, a, b, start, end):
    """Edge in z = 0 of the 2D curve c2 on [a, b], its ends moved to start and end (Vector2d)."""
    if isinstance(c2, Part.Geom2d.BSplineCurve2d):
        c = c2.copy()
        if c.isPeriodic():
            c.setNotPeriodic()
        c.segment(a, b)
        poles = [V(p.x, p.y, 0) for p in c.getPoles()]
        poles[0], poles[-1] = V(start.x, start.y, 0), V(end.x, end.y, 0)
        c3 = Part.BSplineCurve()
        c3.buildFromPolesMultsKnots(poles, c.getMultiplicities(), c.getKnots(), False, c.Degree, c.getWeights())
        return c3.toShape()
    if isinstance(c2, (Part.Geom2d.Line2d, Part.Geom2d.Line2dSegment)):
        return Part.LineSegment(V(start.x, start.y, 0), V(end.x, end.y, 0)).toShape()
    return _curve3d(c2.toBSpline(a, b), a, b, start, end) if hasattr(c2, "toBSpline") else None


def uv_face(face):
    """The face's trimmed domain as a planar face in z = 0 (x = u, y = v)."""
    wires = []
    for w in face.Wires:
        ends = []
        for e in w.OrderedEdges:
            c2, a, b = face.curveOnSurface(e)
            p, q = c2.value(a), c2.value(b)
            rev = e.Orientation == "Reversed"
            ends.append([c2, a, b, q if rev else p, p if rev else q, rev])
        for i, cur in enumerate(ends):  # snap each junction to the mean of the two ends
            nxt = ends[(i + 1) % len(ends)]
            m = V2((cur[4].x + nxt[3].x) / 2, (cur[4].y + nxt[3].y) / 2)
            cur[4], nxt[3] = m, m
        edges = [_curve3d(c2, a, b, q, p) if rev else _curve3d(c2, a, b, p, q) for c2, a, b, p, q, rev in ends]
        wires.append(Part.Wire(edges))
    uvf = Part.Face(wires[0])
    for w in wires[1:]:
        uvf = uvf.cut(Part.Face(w)).Faces[0]
    return uvf


def _curve2d(e):
    """(Geom2d curve, first, last) of an edge in z = 0, its ends moved onto the edge's vertices
    (so that neighbouring edges meet exactly on the surface: the Boolean's vertices are within
    its tolerance only, which the surface's parametric scale can stretch beyond OCC's 1e-7)."""
    a, b = e.ParameterRange
    ends = [v.Point for v in e.Vertexes]
    p, q = e.valueAt(a), e.valueAt(b)
    P = min(ends, key=lambda x: (x - p).Length)
    Q = min(ends, key=lambda x: (x - q).Length) if len(ends) < 2 else [x for x in ends if x is not P][0]
    c = e.Curve
    if isinstance(c, Part.BSplineCurve):
        c = c.copy()
        if c.isPeriodic():
            c.setNotPeriodic()
        c.segment(a, b)
        poles = [V2(x.x, x.y) for x in c.getPoles()]
        poles[0], poles[-1] = V2(P.x, P.y), V2(Q.x, Q.y)
        c2 = Part.Geom2d.BSplineCurve2d()
        c2.buildFromPolesMultsKnots(poles, c.getMultiplicities(), c.getKnots(), False, c.Degree, c.getWeights())
        return c2, c2.FirstParameter, c2.LastParameter
    ln = Part.Geom2d.Line2dSegment(V2(P.x, P.y), V2(Q.x, Q.y))
    return ln, ln.FirstParameter, ln.LastParameter


def on_surface(planar, surf):
    """The planar face (z = 0, x = u, y = v) carried onto surf: its curves as p-curves."""
    wires = []
    for w in planar.Wires:
        wires.append(Part.Wire([c2.toShape(surf, a, b) for c2, a, b in map(_curve2d, w.OrderedEdges)]))
    face = Part.Face(surf, wires[0])
    for w in wires[1:]:
        face = Part.Face(face, w)
    if not face.isValid():  # e.g. a side on a collapsed (degenerate) iso-line of surf
        face.fix(1e-7, 1e-7, 1e-4)
        face = face.Faces[0] if face.ShapeType != "Face" else face
    return face


def _rect(a0, a1, b0, b1):
    return Part.Face(Part.makePolygon([V(a0, b0, 0), V(a1, b0, 0), V(a1, b1, 0), V(a0, b1, 0), V(a0, b0, 0)]))


def _crossed(uvf, us, vs):
    """(k, k) bool: grid cells that the domain's boundary (a fine polyline) passes through or near."""
    k = len(us) - 1
    hit = np.zeros((k, k), bool)
    du, dv = (us[-1] - us[0]) / k, (vs[-1] - vs[0]) / k
    margin = 1e-3
    for e in uvf.Edges:
        P = np.array([(p.x, p.y) for p in e.discretize(Deflection=1e-4 * min(du, dv))])
        lo, hi = np.minimum(P[:-1], P[1:]), np.maximum(P[:-1], P[1:])
        i0 = np.clip(np.floor((lo[:, 0] - us[0]) / du - margin).astype(int), 0, k - 1)
        i1 = np.clip(np.floor((hi[:, 0] - us[0]) / du + margin).astype(int), 0, k - 1)
        j0 = np.clip(np.floor((lo[:, 1] - vs[0]) / dv - margin).astype(int), 0, k - 1)
        j1 = np.clip(np.floor((hi[:, 1] - vs[0]) / dv + margin).astype(int), 0, k - 1)
        for a, b, c, d in zip(i0, i1, j0, j1):
            hit[a:b + 1, c:d + 1] = True
    return hit


def _piece(surf, a0, a1, b0, b1):
    s = surf.copy()  # segment changes its surface in place
    s.segment(a0, a1, b0, b1)
    return s


def split_face(face, k, uvf=None):
    """Pieces (Part.Face list) of face on a k x k grid of its parameter box, and how: 'whole',
    'grid' (untrimmed), 'cut' (trimmed, planar Booleans) or 'centres' (the fallback)."""
    face, surf = bspline_face(face)
    u0, u1, v0, v1 = face.ParameterRange
    us, vs = np.linspace(u0, u1, k + 1), np.linspace(v0, v1, k + 1)
    cells = [(i, j) for i in range(k) for j in range(k)]
    uvf = uvf if uvf is not None else uv_face(face)
    if abs(uvf.Area - (u1 - u0) * (v1 - v0)) <= 1e-9 * (u1 - u0) * (v1 - v0):
        if k == 1:
            return [face], "whole"
        return [Part.Face(_piece(surf, us[i], us[i + 1], vs[j], vs[j + 1])) for i, j in cells], "grid"
    try:
        hit, out = _crossed(uvf, us, vs), []
        for i, j in cells:
            a0, a1, b0, b1 = us[i], us[i + 1], vs[j], vs[j + 1]
            if not hit[i, j]:
                if uvf.isInside(V((a0 + a1) / 2, (b0 + b1) / 2, 0), 1e-9, True):
                    out.append(Part.Face(_piece(surf, a0, a1, b0, b1)))
                continue
            R = _rect(a0, a1, b0, b1)
            com = uvf.common(R)
            if not com.Faces:
                continue
            s = _piece(surf, a0, a1, b0, b1)
            if abs(com.Area - R.Area) <= 1e-12 * R.Area:
                out.append(Part.Face(s))
            else:
                out.extend(on_surface(f, s) for f in com.Faces)
        if all(f.isValid() for f in out):
            return out, "cut"
    except Exception:  # noqa: BLE001 - OpenCascade's failures: the fallback below
        pass
    out = [Part.Face(_piece(surf, us[i], us[i + 1], vs[j], vs[j + 1])) for i, j in cells
           if face.isPartOfDomain((us[i] + us[i + 1]) / 2, (vs[j] + vs[j + 1]) / 2)]
    return out, "centres"


def face_plan(faces):
    """(area, uv fill fraction, uv face or None) of each face: the split's inputs."""
    plan = []
    for f in faces:
        bf, _ = bspline_face(f)
        u0, u1, v0, v1 = bf.ParameterRange
        try:
            uvf = uv_face(bf)
            fill = min(1.0, uvf.Area / ((u1 - u0) * (v1 - v0)))
        except Exception:  # noqa: BLE001
            uvf, fill = None, 1.0
        plan.append((f.Area, max(fill, 1e-3), uvf))
    return plan


def grid_sizes(plan, target):
    """k of each face so that about target pieces result: k^2 * fill pieces a face, k in
    proportion to the square root of the face's share of the area (at least 1)."""
    area = sum(a for a, _, _ in plan)

    def ks(scale):
        return [max(1, int(round(math.sqrt(scale * target * a / area / fill)))) for a, fill, _ in plan]

    def count(scale):
        return sum(max(1, round(k * k * fill)) for k, (_, fill, _) in zip(ks(scale), plan))

    lo, hi = 1e-3, 1e3
    for _ in range(60):  # bisection on the scale of the targets, in log
        mid = math.sqrt(lo * hi)
        lo, hi = (mid, hi) if count(mid) < target else (lo, mid)
    return ks(lo) if abs(count(lo) - target) <= abs(count(hi) - target) else ks(hi)


def split_shape(shape, target, progress=None):
    """(compound of the pieces, {method: faces split so}) of shape with about target faces."""
    plan = face_plan(shape.Faces)
    pieces, how = [], {}
    for n, (f, k, (_, _, uvf)) in enumerate(zip(shape.Faces, grid_sizes(plan, target), plan)):
        if uvf is None:
            out, m = [f], "whole (no domain)"
        else:
            out, m = split_face(f, k, uvf)
        pieces.extend(out)
        how[m] = how.get(m, 0) + 1
        if progress:
            progress("face %d/%d: k = %d, %d pieces (%s)" % (n + 1, len(shape.Faces), k, len(out), m))
    return Part.Compound(pieces), how
