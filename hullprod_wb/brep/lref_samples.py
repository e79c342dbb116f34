"""Nodes of the tessellation that gives the automatic reference length (paper eq:refs).

OpenCascade tessellates the faces at SAMPLE_DEFLECTION of the shape's bounding-box diagonal
(whatever the display settings); the area-weighted nodes then give the principal-axis
span (core.reference_length). The tessellation holds the interpreter while it runs, so a
file's assessment starts it in a child forked right after reading (start), which works
beside the loading of the numerical modules and hands back the same numbers as running it
here. Nothing in this module needs numpy.
"""
import os
import struct
import time
from array import array

from .face_pool import fork_is_safe
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
    forking is safe) or else at the first result(); result() returns it and the seconds it
    took."""

    def __init__(self, faces, deflection, fork=True):
        self.faces, self.deflection = list(faces), float(deflection)
        self._value, self._child = None, None
        if fork and fork_is_safe():
            r, w = os.pipe()
            pid = os.fork()
            if pid == 0:  # child: tessellate, send, leave without the parent's exit handlers
                os.close(r)
                try:
                    t = time.perf_counter()
                    pts, tris = tessellate_faces(self.faces, self.deflection)
                    head = struct.pack("<qqd", len(pts), len(tris), time.perf_counter() - t)
                    with os.fdopen(w, "wb") as fh:
                        fh.write(head + pts.tobytes() + tris.tobytes())
                finally:
                    os._exit(0)
            os.close(w)
            self._child = (pid, r)

    def result(self):
        """(points, triangles, seconds): the arrays of tessellate_faces."""
        if self._value is None and self._child is not None:
            pid, r = self._child
            self._child = None
            with os.fdopen(r, "rb") as fh:
                data = fh.read()
            os.waitpid(pid, 0)
            if len(data) >= 24:  # else the child died before sending: tessellate here
                n_p, n_t, seconds = struct.unpack("<qqd", data[:24])
                pts, tris = array("d"), array("q")
                pts.frombytes(data[24:24 + 8 * n_p])
                tris.frombytes(data[24 + 8 * n_p:24 + 8 * (n_p + n_t)])
                if len(pts) == n_p and len(tris) == n_t:
                    self._value = (pts, tris, seconds)
        if self._value is None:
            t = time.perf_counter()
            pts, tris = tessellate_faces(self.faces, self.deflection)
            self._value = (pts, tris, time.perf_counter() - t)
        return self._value

    def close(self):
        """Stop and reap a child whose result is no longer wanted."""
        if self._child is not None:
            pid, r = self._child
            self._child = None
            try:
                os.kill(pid, 9)
                os.waitpid(pid, 0)
            except OSError:
                pass
            os.close(r)


def read_and_start(path, faces=None):
    """load_brep(path, faces) with the seconds it took (read_seconds) and its L_ref
    tessellation started beside (lref_tessellation)."""
    t = time.perf_counter()
    inp = load_brep(path, faces)
    inp.read_seconds = time.perf_counter() - t
    inp.lref_tessellation = LrefTessellation([f for _, f in inp.faces],
                                             SAMPLE_DEFLECTION * inp.shape.BoundBox.DiagonalLength)
    return inp
