"""Nodes of the tessellation that gives the automatic reference length (paper eq:refs).

OpenCascade tessellates the faces at SAMPLE_DEFLECTION of the shape's bounding-box diagonal
(whatever the display settings); the area moments of its triangles then give the
principal-axis span (core.reference_length). The tessellation holds the interpreter while it runs, and on
FreeCAD 1.x starts OpenCascade's thread pool in the process that runs it, so it runs in a
child forked where forking is safe (LrefTessellation; read_and_start starts it right after
loading a file), which works beside the rest of the set-up and hands back the same numbers
as running it here. Nothing in this module needs numpy.
"""
import time
from array import array

from ...core.processes import ForkedCall
from .loading import load_brep

#: Deflection of the L_ref tessellation, as a fraction of the bounding-box diagonal.
SAMPLE_DEFLECTION = 2e-2


def tessellate_faces(faces, deflection):
    """OpenCascade's tessellation of the faces (Part.Face list) at deflection: the nodes as
    flat x, y, z doubles and the triangles as flat node indices into them (array 'd' and
    'q'); faces without a tessellation are left out."""
    points, triangles = array("d"), array("q")
    offset = 0
    for face in faces:
        pts, tris = face.tessellate(deflection)
        if len(pts) == 0 or len(tris) == 0:
            continue
        for p in pts:
            points.extend((p.x, p.y, p.z))
        for t in tris:
            triangles.extend((t[0] + offset, t[1] + offset, t[2] + offset))
        offset += len(pts)
    return points, triangles


class LrefTessellation:
    """tessellate_faces(faces, deflection), made in a child forked now (with fork, where
    forking is safe: processes.ForkedCall) or else at the first result(); result() returns
    (points, triangles, seconds it took)."""

    def __init__(self, faces, deflection, fork=True):
        self.faces, self.deflection = list(faces), float(deflection)
        self.call = ForkedCall(self._tessellate, fork)

    def _tessellate(self):
        t = time.perf_counter()
        pts, tris = tessellate_faces(self.faces, self.deflection)
        return pts, tris, time.perf_counter() - t

    def result(self):
        return self.call.result()

    def close(self):
        """Stop and reap a child whose result is no longer wanted."""
        self.call.close()


def read_and_start(path, faces=None):
    """load_brep(path, faces) with the seconds it took (read_seconds) and its L_ref
    tessellation started beside (lref_tessellation)."""
    t = time.perf_counter()
    inp = load_brep(path, faces)
    inp.read_seconds = time.perf_counter() - t
    inp.lref_tessellation = LrefTessellation([f for _, f in inp.faces],
                                             SAMPLE_DEFLECTION * inp.shape.BoundBox.DiagonalLength)
    return inp
