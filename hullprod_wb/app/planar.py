"""Planar faces of a BRep shape (a deck, a transom, flat plates closing a hull): the faces
an analysis may leave out (SkipPlanarFaces)."""


#: A face is planar when it lies within this fraction of its own size of a plane.
PLANAR_TOLERANCE = 1.0e-7


def planar_faces(shape, faces=None):
    """1-based numbers of the planar faces of shape among faces (None: all): planes, and
    faces of other surface types (a flat B-spline deck) within PLANAR_TOLERANCE of their
    bounding-box diagonal of a plane (OpenCascade's plane search, Shape.findPlane)."""
    all_faces = shape.Faces
    out = []
    for n in faces or range(1, len(all_faces) + 1):
        face = all_faces[n - 1]
        if type(face.Surface).__name__ == "Plane":
            out.append(n)
            continue
        try:
            plane = face.findPlane(PLANAR_TOLERANCE * max(face.BoundBox.DiagonalLength, 1e-12))
        except Exception:  # OpenCascade cannot search this face: not treated as planar
            plane = None
        if plane is not None:
            out.append(n)
    return out
