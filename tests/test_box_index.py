"""provenance.BoxIndex, which finds the faces that may share an edge: for any point it gives
every box that holds the point (inclusive bounds, as OpenCascade's BoundBox.isInside), in
ascending order, with large boxes and flat ones too."""
import random

from conftest import needs_freecad
from hullprod_wb.brep.reading.provenance import BoxIndex


def holds(b, p):
    return all(b[k] <= p[k] <= b[k + 3] for k in range(3))


def random_boxes(rng, n):
    boxes = []
    for i in range(n):
        lo = [rng.uniform(0, 100), rng.uniform(0, 10), rng.uniform(-5, 5)]
        size = [rng.choice([0.0, rng.uniform(0, 3), rng.uniform(0, 60)]) for _ in range(3)]
        boxes.append(tuple(lo) + tuple(lo[k] + size[k] for k in range(3)))
    boxes.append((0.0, 0.0, -5.0, 160.0, 13.0, 8.0))  # one box over everything
    return boxes


def test_near_is_every_box_that_holds_the_point_in_order():
    rng = random.Random(7)
    for n in (1, 5, 60, 800):
        boxes = random_boxes(rng, n)
        index = BoxIndex(boxes)
        points = [(rng.uniform(-10, 170), rng.uniform(-2, 15), rng.uniform(-7, 9)) for _ in range(300)]
        points += [b[:3] for b in boxes[:50]] + [b[3:] for b in boxes[:50]]  # on the bounds
        for p in points:
            near = index.near(p)
            assert near == sorted(set(near))
            assert [i for i, b in enumerate(boxes) if holds(b, p)] == [i for i in near if holds(boxes[i], p)]


def test_a_large_box_is_kept_apart_and_small_boxes_are_bucketed():
    """8,000 unit boxes in a 20 x 20 x 20 block and one box over all of them: the large box
    is in a list of its own, and a point meets a handful of boxes, not all of them."""
    boxes = [(float(i), float(j), float(k), i + 1.0, j + 1.0, k + 1.0)
             for i in range(20) for j in range(20) for k in range(20)]
    boxes.append((0.0, 0.0, 0.0, 20.0, 20.0, 20.0))
    index = BoxIndex(boxes)
    assert index.large == [len(boxes) - 1]
    near = index.near((10.5, 3.5, 7.5))
    assert 10 * 400 + 3 * 20 + 7 in near and len(boxes) - 1 in near and len(near) < 10


@needs_freecad
def test_points_find_the_edges_distance_to_shape_finds():
    """provenance._on_edges (a projection on the edge's curve first, the distance to the edge
    where that does not decide, edges through FaceEdges' index) finds the same first edge
    and parameter as OpenCascade's distance to each edge in order, for points on, near and
    beyond the edges of a face of 48 edges."""
    import math
    from hullprod_wb.freecad_env import import_freecad
    FreeCAD = import_freecad()
    import Part
    from hullprod_wb.brep.reading.provenance import FaceEdges, _enlarged, _on_edges
    V = FreeCAD.Vector
    ring = [V(10 * math.cos(2 * math.pi * i / 48), 6 * math.sin(2 * math.pi * i / 48), 0.0) for i in range(48)]
    face = Part.Face(Part.Wire(Part.makePolygon(ring + [ring[0]])))
    tol = 1e-3
    edges = FaceEdges([(e, _enlarged(e.BoundBox, tol)) for e in face.Edges])
    assert edges.index is not None

    def reference(p):
        vertex = Part.Vertex(p)
        for e, bb in edges.pairs:
            if bb.isInside(p) and e.distToShape(vertex)[0] < tol:
                return e, e.Curve.parameter(p)
        return None

    rng = random.Random(3)
    points = []
    for e in face.Edges:
        a, b = e.FirstParameter, e.LastParameter
        d = e.Curve.Direction
        normal = V(-d.y, d.x, 0.0)
        for t in (a, b, a + 0.3 * (b - a), a - 0.5 * tol, b + 0.9 * tol, b + 2.0 * tol):
            for off in (0.0, 0.5 * tol, 0.99 * tol, 1.5 * tol, rng.uniform(-tol, tol)):
                points.append(e.Curve.value(t) + normal * off)
    found = 0
    for p in points:
        ours, ref = _on_edges(p, edges, tol), reference(p)
        assert (ours is None) == (ref is None)
        if ref is not None:
            found += 1
            assert ours[0].isSame(ref[0]) and ours[1] == ref[1]
    assert 0 < found < len(points)
