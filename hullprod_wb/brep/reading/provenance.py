"""Representation provenance of a BRep: faces, surface types, areas, topology, edge
continuity (C0 creases) and whether the shape is a half or a full hull.

Plain Python and OpenCascade only (no numpy): the process that reads a file for its plain
records (record_reader) makes it without loading numpy.
"""
import math
from collections import Counter

from .occ_records import linspace
from .record_keys import edges_key

#: Normals on the two sides of a shared edge differing by more than this are a C0 crease.
CREASE_ANGLE_DEG = 1.0
#: Samples per edge for the continuity check.
EDGE_SAMPLES = 5


def _edge_params(edge, n=EDGE_SAMPLES):
    a, b = edge.FirstParameter, edge.LastParameter
    return [a + (b - a) * t for t in linspace(0.05, 0.95, n)]


def _normals_on_edge(face, edge, ts, points):
    """Unit normals (k, 3) of face at parameters ts (k,) of its boundary edge (points: the
    3-D points): (u, v) from the edge's p-curve on the face (exact, cheap), else by
    projection. A normal that is undefined (degenerate point) is None."""
    pc = face.curveOnSurface(edge)
    out = [None] * len(ts)
    for i, (t, p) in enumerate(zip(ts, points)):
        try:
            if pc is not None:
                uv = pc[0].value(t)
                u, v = uv.x, uv.y
            else:
                u, v = face.Surface.parameter(p)
            n = face.normalAt(u, v)
            out[i] = (n.x, n.y, n.z)
        except Exception:  # normal undefined at a degenerate point
            continue
    return out


def _on_edges(point, edges, tol):
    """(edge, parameter) of the first edge within tol of point, or None; edges: FaceEdges,
    a box that does not hold the point ruling its edge out. The point's projection on the
    edge's curve, when it falls inside the edge and within tol, decides at once (the edge's
    distance is at most the projection's); otherwise OpenCascade's distance to the edge
    does."""
    vertex = None
    for e, bb in edges.near(point):
        if not bb.isInside(point):
            continue
        curve = e.Curve
        t = curve.parameter(point)
        if e.FirstParameter <= t <= e.LastParameter and (curve.value(t) - point).Length < tol:
            return e, t
        if vertex is None:
            import Part
            vertex = Part.Vertex(point)
        if e.distToShape(vertex)[0] < tol:
            return e, t
    return None


class BoxIndex:
    """Axis-aligned boxes bucketed on a uniform grid: near(point) gives, in ascending order,
    the indices of the boxes that may hold the point (a superset of those that do).

    The grid has about one cell per median box extent along each axis (at most GRID_CELLS
    along any); a box covering more than LARGE_BOX cells is kept in a list every query
    returns, so a few large faces cost no more than a list. Finding a face's neighbours then
    costs about the faces near it, not all faces."""

    GRID_CELLS = 64
    LARGE_BOX = 512

    def __init__(self, bounds):
        """bounds: [(xmin, ymin, zmin, xmax, ymax, zmax)] of the boxes."""
        self.lo = [min(b[k] for b in bounds) for k in range(3)] if bounds else [0.0] * 3
        hi = [max(b[k + 3] for b in bounds) for k in range(3)] if bounds else [0.0] * 3
        self.cell = []
        for k in range(3):
            span = hi[k] - self.lo[k]
            extents = sorted(b[k + 3] - b[k] for b in bounds) or [0.0]
            typical = max(extents[len(extents) // 2], span / self.GRID_CELLS)
            self.cell.append(typical if typical > 0.0 else 1.0)
        self.buckets, self.large = {}, []
        for i, b in enumerate(bounds):
            lo, hi_ = self._cell_of(b[:3]), self._cell_of(b[3:])
            count = 1
            for k in range(3):
                count *= hi_[k] - lo[k] + 1
            if count > self.LARGE_BOX:
                self.large.append(i)
                continue
            for cx in range(lo[0], hi_[0] + 1):
                for cy in range(lo[1], hi_[1] + 1):
                    for cz in range(lo[2], hi_[2] + 1):
                        self.buckets.setdefault((cx, cy, cz), []).append(i)

    def _cell_of(self, point):
        return tuple(int(math.floor((point[k] - self.lo[k]) / self.cell[k])) for k in range(3))

    def near(self, point):
        """Sorted indices of the boxes that may hold point (x, y, z)."""
        found = self.buckets.get(self._cell_of(point), [])
        return sorted(found + self.large) if self.large else found


class FaceEdges:
    """A face's boundary edges with their boxes enlarged by the tolerance, (edge, box)
    pairs in the face's order; near(point) gives, in that order, those whose boxes may hold
    the point (through a BoxIndex when the face has more than INDEXED_EDGES of them)."""

    INDEXED_EDGES = 16

    def __init__(self, pairs):
        self.pairs = pairs
        self.index = BoxIndex([_bounds(bb) for _, bb in pairs]) if len(pairs) > self.INDEXED_EDGES else None

    def __iter__(self):
        return iter(self.pairs)

    def near(self, point):
        if self.index is None:
            return self.pairs
        return [self.pairs[i] for i in self.index.near(point)]


def _enlarged(bb, tol):
    out = type(bb)(bb)  # a copy
    out.enlarge(tol)
    return out


def _bounds(bb):
    return (bb.XMin, bb.YMin, bb.ZMin, bb.XMax, bb.YMax, bb.ZMax)


def shape_boxes(shape, faces):
    """Bounding boxes of shape, of each of faces (list of (number, Part.Face)) and of each
    face's edges, to be taken before anything is tessellated: OpenCascade's boxes shrink to a
    triangulation once there is one (they then no longer hold the curves), and the provenance
    should not depend on it (shape_provenance)."""
    return shape.BoundBox, [f.BoundBox for _, f in faces], [[e.BoundBox for e in f.Edges] for _, f in faces]


def edge_report(shape, faces, boxes=None, store=None, digests=None):
    """Free and shared boundary edges of the assessed faces, with continuity across them.

    A face's boundary edge is shared when sample points along it lie on boundary edges of
    another assessed face (within 1e-5 of the shape's size); this covers sewn shells, unsewn
    IGES faces and T-junctions of edges alike. Shared lengths count each shared curve once
    (half the sum over the two sides). Normals of the two faces differing by more than
    CREASE_ANGLE_DEG at any sample make a C0 crease (normals from the edges' p-curves).
    Each face's part (_face_edges) is summed in the faces' order. With a result store
    (core.result_store) and each face's digest of its OpenCascade data (digests, taken
    before any tessellation), a face's part is kept under a key of its digest, its number,
    the tolerance and the numbers and digests of the faces whose boxes hold its edges' first
    points (every face its part can depend on), and taken from the store when they recur.
    """
    shape_bb, face_bbs, edge_bbs = boxes or shape_boxes(shape, faces)
    size = max(shape_bb.DiagonalLength, 1e-300)
    tol = 1e-5 * size
    boxes = []
    for (number, face), bb, ebbs in zip(faces, face_bbs, edge_bbs):
        edges = []
        for e, ebb in zip(face.Edges, ebbs):
            if e.Length > tol:
                edges.append((e, _enlarged(ebb, tol)))
        boxes.append((number, face, _enlarged(bb, tol), FaceEdges(edges)))
    index = BoxIndex([_bounds(b[2]) for b in boxes])
    total = {"n_free": 0, "free_len": 0.0, "n_shared": 0, "shared_len": 0.0, "crease_len": 0.0}
    creases = {}
    for k in range(len(boxes)):
        part = _stored_face_edges(k, boxes, index, tol, store, digests)
        for name in total:
            total[name] += part[name]
        for a, b, length, angle in part["creases"]:
            rec = creases.setdefault((a, b), {"faces": [a, b], "length": 0.0, "max_normal_angle_deg": 0.0})
            rec["length"] += length
            rec["max_normal_angle_deg"] = max(rec["max_normal_angle_deg"], angle)
    return {"free_edges": total["n_free"], "free_edge_length": total["free_len"],
            "shared_edge_sides": total["n_shared"], "shared_edge_length": total["shared_len"],
            "c0_crease_face_pairs": len(creases), "c0_crease_length": total["crease_len"],
            "crease_angle_threshold_deg": CREASE_ANGLE_DEG, "creases": list(creases.values())}


def _stored_face_edges(k, boxes, index, tol, store, digests):
    """_face_edges of face k, from the store when its key is there (see edge_report)."""
    number, _, _, edges = boxes[k]
    samples = [(edge, _edge_params(edge)) for edge, _ in edges]
    samples = [(edge, ts, [edge.valueAt(t) for t in ts]) for edge, ts in samples]
    key = None
    if store is not None and digests is not None and digests[k] is not None:
        near = sorted({i for _, _, pts in samples for i in index.near(pts[0]) if boxes[i][2].isInside(pts[0])})
        if all(digests[i] is not None for i in near):
            key = edges_key(digests[k], number, tol, [(boxes[i][0], digests[i]) for i in near])
    if store is None:
        return _face_edges(k, samples, boxes, index, tol)
    return store.made(key, lambda: _face_edges(k, samples, boxes, index, tol))


def _face_edges(k, samples, boxes, index, tol):
    """Face k's part of the edge report: free and shared edge counts and lengths, and its
    creases [face, partner (the lower number first), length, largest normal angle];
    samples: (edge, parameters, points) of its edges."""
    number, face, _, _ = boxes[k]
    part = {"n_free": 0, "free_len": 0.0, "n_shared": 0, "shared_len": 0.0, "crease_len": 0.0}
    creases = {}
    for edge, ts, pts in samples:  # degenerated edges (collapsed sides of a patch) are left out
        partner = None
        # the faces in the order given, among those whose box may hold the first point
        for other, oface, bb, oedges in (boxes[i] for i in index.near(pts[0])):
            if other == number or not all(bb.isInside(p) for p in pts):
                continue
            hits = []
            for p in pts:
                hit = _on_edges(p, oedges, tol)
                if hit is None:
                    break
                hits.append(hit)
            if len(hits) == len(pts):
                partner = (other, oface, hits)
                break
        if partner is None:
            part["n_free"] += 1
            part["free_len"] += edge.Length
            continue
        part["n_shared"] += 1
        part["shared_len"] += 0.5 * edge.Length
        mine = _normals_on_edge(face, edge, ts, pts)
        theirs = [_normals_on_edge(partner[1], oe, [ot], [p])[0] for (oe, ot), p in zip(partner[2], pts)]
        angles = [math.degrees(math.acos(min(1.0, abs(a[0] * b[0] + a[1] * b[1] + a[2] * b[2]))))
                  for a, b in zip(mine, theirs) if a is not None and b is not None]
        max_angle = max(angles) if angles else None
        if max_angle is not None and max_angle > CREASE_ANGLE_DEG:
            pair = tuple(sorted((number, partner[0])))
            rec = creases.setdefault(pair, [pair[0], pair[1], 0.0, 0.0])
            rec[2] += 0.5 * edge.Length
            rec[3] = max(rec[3], max_angle)
            part["crease_len"] += 0.5 * edge.Length
    part["creases"] = list(creases.values())
    return part


def hull_side(shape, rel_tol=1e-4, bb=None):
    """'starboard half' / 'port half' (one side of y = 0), 'full' (both) or 'off-centre'
    (bb: the shape's bounding box, when already taken)."""
    bb = bb or shape.BoundBox
    tol = rel_tol * max(bb.XLength, bb.YLength, bb.ZLength)
    if bb.YMin >= -tol and bb.YMax > tol:
        return "starboard half (y >= 0)"
    if bb.YMax <= tol and bb.YMin < -tol:
        return "port half (y <= 0)"
    if bb.YMin < -tol and bb.YMax > tol:
        return "full (both sides of y = 0)"
    return "in the centre plane"


def occ_face_area(face):
    """OpenCascade's area of face (BRepGProp), or None where OpenCascade cannot compute it
    (it raises on some degenerate or nearly flat B-spline faces)."""
    try:
        area = float(face.Area)
    except Exception:  # FreeCADError "Unknown exception while reading attribute 'Area'"
        return None
    return area if math.isfinite(area) else None


def surface_type_name(face):
    try:
        return type(face.Surface).__name__
    except Exception:  # a face without a surface
        return "no surface"


def shape_provenance(shape, faces, areas=None, boxes=None, store=None, digests=None):
    """Provenance dict of the assessed faces of shape (faces: list of (number, Part.Face);
    areas: their OpenCascade areas when already known, None for a face whose area
    OpenCascade cannot compute; boxes: shape_boxes taken before any tessellation, else
    taken now). occ_area sums the faces whose area OpenCascade gives; the others are
    listed in occ_area_failed_faces. store, digests: edge_report's."""
    types = Counter(surface_type_name(f) for _, f in faces)
    areas = [occ_face_area(f) for _, f in faces] if areas is None else list(areas)
    failed = [n for (n, _), a in zip(faces, areas) if a is None]
    occ_area = float(sum(a for a in areas if a is not None))
    boxes = boxes or shape_boxes(shape, faces)
    bb = boxes[0]
    return {
        "faces_total": len(shape.Faces),
        "faces_assessed": len(faces),
        "surface_types": dict(types),
        "occ_area": occ_area,
        "occ_area_note": "FreeCAD Shape.Area at default precision (about 1e-4 relative); not the reference",
        "occ_area_failed_faces": failed,
        "shells": len(shape.Shells),
        "solids": len(shape.Solids),
        "bounding_box": {"xmin": bb.XMin, "xmax": bb.XMax, "ymin": bb.YMin, "ymax": bb.YMax,
                         "zmin": bb.ZMin, "zmax": bb.ZMax},
        "hull_side": hull_side(shape, bb=bb),
        "edges": safe_edge_report(shape, faces, boxes, store, digests),
    }


def safe_edge_report(shape, faces, boxes, store=None, digests=None):
    """edge_report, or the reason it could not be made (a face whose edges or box
    OpenCascade cannot give, e.g. of non-finite geometry)."""
    try:
        return edge_report(shape, faces, boxes, store, digests)
    except Exception as exc:  # OpenCascade raises on invalid (non-finite) boxes and edges
        return {"not_evaluated": "%s: %s" % (type(exc).__name__, " ".join(str(exc).split()))}
