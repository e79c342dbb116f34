"""Distributed fields on a display-only tessellation of BRep faces.

The tessellation (OpenCascade's, with its (u, v) nodes) only carries the samples for
display, export and the automatic reference length: H and K are evaluated exactly at its
nodes and never enter the integrals (paper section 4.1).
"""
import numpy as np

from ..core.fields import DistributedFields
# SAMPLE_DEFLECTION: the deflection of the tessellation whose nodes give the automatic L_ref,
# with or without display fields, so that L_ref never depends on the display settings
from ..core.processes import ForkedCall
from .reading.lref_samples import SAMPLE_DEFLECTION, LrefTessellation  # noqa: F401
from .reading.occ_records import DISPLAY_DEFLECTION, display_mesh  # noqa: F401


def face_display_mesh(mesh, field):
    """(uv (n, 2), field values at uv, triangles (m, 3)) of OpenCascade's tessellation of a
    face, mesh = occ_records.display_mesh(face, deflection).

    FreeCAD's tessellate() reorders and merges nodes; its triangles are mapped back to the
    triangulation's (u, v) nodes by nearest 3-D position.
    """
    pts, tris, uvs = mesh
    uv = np.frombuffer(uvs, dtype=np.float64).reshape(-1, 2)
    if len(pts) == 0 or len(uv) == 0:
        return uv, None, np.zeros((0, 3), dtype=np.int64)
    values = field(uv[:, 0], uv[:, 1])
    P = np.frombuffer(pts, dtype=np.float64).reshape(-1, 3)
    from scipy.spatial import cKDTree  # imported only when fields are wanted
    _, index = cKDTree(values["points"]).query(P)
    T = index[np.frombuffer(tris, dtype=np.int64).reshape(-1, 3)]
    keep = (T[:, 0] != T[:, 1]) & (T[:, 1] != T[:, 2]) & (T[:, 0] != T[:, 2])
    return uv, moved_samples(field, uv, values), T[keep]


#: Fractions of the way from a node that cannot be evaluated to the mean of its nearest
#: regular nodes (in (u, v)) tried in turn; the first regular point gives the node's field.
MOVE_FRACTIONS = (1e-3, 1e-2, 1e-1, 0.5)


def moved_samples(field, uv, values, neighbours=3):
    """values with the field at the nodes that are not regular (or whose K is not finite)
    taken from (u, v) points moved a fraction (MOVE_FRACTIONS) of the way to the mean of
    their `neighbours` nearest regular nodes; positions stay the nodes'. A node with no
    regular point on the way stays as it was (not regular)."""
    bad = ~(values["regular"] & np.isfinite(values["K"]))
    good = np.flatnonzero(~bad)
    if not bad.any() or len(good) == 0:
        return values
    from scipy.spatial import cKDTree
    todo = np.flatnonzero(bad)
    _, near = cKDTree(uv[good]).query(uv[todo], k=min(neighbours, len(good)))
    target = uv[good][near.reshape(len(todo), -1)].mean(axis=1)
    out = dict(values)
    for k in ("K", "H", "k1", "k2", "regular"):
        out[k] = np.array(values[k], copy=True)
    for t in MOVE_FRACTIONS:
        if len(todo) == 0:
            break
        p = uv[todo] + t * (target - uv[todo])
        f = field(p[:, 0], p[:, 1])
        ok = f["regular"] & np.isfinite(f["K"])
        for k in ("K", "H", "k1", "k2", "regular"):
            out[k][todo[ok]] = f[k][ok]
        todo, target = todo[~ok], target[~ok]
    return out


def sample_faces(face_fields, deflection, meshes=None):
    """Exact samples at the display nodes of every face.

    face_fields: list of (face number, FaceField); meshes: their display tessellations
    (occ_records.display_mesh) when already made, else those of the fields' faces at
    deflection. Returns sample_meshes's dict, or None when no face has a display node.
    """
    if meshes is None:  # meshed in a child where forking is safe: this process starts no mesher threads
        meshes = ForkedCall(lambda: [display_mesh(ff.face, deflection) for _, ff in face_fields]).result()
    return sample_meshes([n for n, _ in face_fields], meshes,
                         lambda i, mesh: face_display_mesh(mesh, face_fields[i][1]))


def sample_meshes(numbers, meshes, sample):
    """The display samples of faces numbered numbers with display meshes meshes, face i's
    (uv, field values, triangles) given by sample(i, meshes[i]) (face_display_mesh's).
    Returns dict of concatenated arrays: points (n, 3), triangles (m, 3), uv (n, 2), K, H,
    k1, k2 (n,), valid (n,) bool, face_id (n,) int (1-based), and node_area (n,)
    barycentric areas of the display triangles; None when no face has a display node."""
    parts = {k: [] for k in ("points", "triangles", "uv", "K", "H", "k1", "k2", "valid", "face_id")}
    offset = 0
    for i, number in enumerate(numbers):
        uv, f, T = sample(i, meshes[i])
        if f is None:
            continue
        parts["points"].append(f["points"])
        parts["triangles"].append(T + offset)
        parts["uv"].append(uv)
        for k in ("K", "H", "k1", "k2"):
            parts[k].append(f[k])
        parts["valid"].append(f["regular"] & np.isfinite(f["K"]))
        parts["face_id"].append(np.full(len(uv), number, dtype=np.int32))
        offset += len(uv)
    if not parts["points"]:
        return None
    out = {k: np.concatenate(v) for k, v in parts.items()}
    out["node_area"] = node_areas(out["points"], out["triangles"])
    return out


def tessellation_samples(faces, deflection, tessellation=None):
    """Points (n, 3), triangles (m, 3) and node_area (n,) of OpenCascade's tessellation of
    the faces (a list of Part.Face) at deflection, without fields: all the automatic reference length needs
    (tessellation: an LrefTessellation of them already started; else one made now, in a
    child where forking is safe, so that no mesher thread starts here). Returns a dict with
    points, triangles and node_area, or None when no face has a tessellation."""
    tess = tessellation or LrefTessellation(faces, deflection)
    try:
        pts, tris, _ = tess.result()
    finally:
        tess.close()
    return node_samples(pts, tris)


def node_samples(pts, tris):
    """dict(points (n, 3), triangles (m, 3), node_area (n,)) of a tessellation given as
    lref_samples.tessellate_faces gives it (flat x, y, z doubles, flat triangle node
    indices), or None without triangles."""
    if len(tris) == 0:
        return None
    P = np.frombuffer(pts, dtype=np.float64).reshape(-1, 3)
    T = np.frombuffer(tris, dtype=np.int64).reshape(-1, 3)
    return {"points": P, "triangles": T, "node_area": node_areas(P, T)}


def node_areas(P, T):
    """Barycentric node areas (n,) of the triangles T (m, 3) over the points P (n, 3): a third
    of each triangle's area to each of its nodes."""
    area = 0.5 * np.linalg.norm(np.cross(P[T[:, 1]] - P[T[:, 0]], P[T[:, 2]] - P[T[:, 0]]), axis=1)
    return np.bincount(T.ravel(), weights=np.repeat(area / 3.0, 3), minlength=len(P))


def display_fields(samples, lref, thresholds):
    """DistributedFields (kind 'brep-display') from sample_faces() output."""
    return DistributedFields(points=samples["points"], triangles=samples["triangles"], K=samples["K"],
                             H=samples["H"], valid=samples["valid"], lref=lref, tau_H=thresholds.tau_H,
                             tau_K=thresholds.tau_K, weights=None, kind="brep-display",
                             extra={"face_id": samples["face_id"], "k1": samples["k1"],
                                    "k2": samples["k2"]})
