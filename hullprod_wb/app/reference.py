"""The automatic L_ref proposal shown before a run (paper eq:refs).

Same method as the assessment's automatic L_ref (core.reference_length): the span along
the first principal axis of the area of a triangulation; here a display tessellation
(BRep) or the mesh itself, so for a BRep the proposal can differ slightly from the value
the run then reports as 'automatic'.
"""
import numpy as np

from ..core.errors import InputError
from ..core.reference_length import AUTOMATIC_METHOD, automatic_length

#: Tessellation tolerance for the proposal, as a fraction of the bounding-box diagonal.
TESSELLATION_FRACTION = 2.0e-3


def surface_samples(source, faces=None):
    """(points (n, 3), triangles (m, 3)) of a Part object's faces or a Mesh object."""
    if hasattr(source, "Shape"):
        shape = source.Shape
        all_faces = shape.Faces
        chosen = faces or range(1, len(all_faces) + 1)
        tol = max(shape.BoundBox.DiagonalLength * TESSELLATION_FRACTION, 1e-9)
        pts, tris, off = [], [], 0
        for n in chosen:
            if not 1 <= n <= len(all_faces):
                raise InputError("face %d does not exist: %s has faces 1..%d" % (n, source.Label, len(all_faces)))
            p, t = all_faces[n - 1].tessellate(tol)
            if not len(t):
                continue
            pts.append(np.array(p, float).reshape(-1, 3))
            tris.append(np.array(t, np.int64).reshape(-1, 3) + off)
            off += len(p)
        if not pts:
            raise InputError("%s has no face that can be sampled" % source.Label)
        return np.vstack(pts), np.vstack(tris)
    if hasattr(source, "Mesh"):
        p, t = source.Mesh.Topology
        if not len(t):
            raise InputError("mesh %s has no triangles" % source.Label)
        return np.array(p, float).reshape(-1, 3), np.array(t, np.int64).reshape(-1, 3)
    raise InputError("%s has neither a Part shape nor a mesh" % getattr(source, "Label", source))


def proposed_lref(source, faces=None):
    """dict(value, method, units) of the automatic L_ref proposal for source."""
    P, T = surface_samples(source, faces)
    units = "mm" if hasattr(source, "Shape") else "mesh units"
    return {"value": automatic_length(P, T), "method": AUTOMATIC_METHOD, "units": units}
