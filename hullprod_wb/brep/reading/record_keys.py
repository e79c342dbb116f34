"""Keys of a face's record (occ_records.FaceData) for the faces' store: its digest without
its number, and the keys of what the reading process keeps there: OpenCascade's area of the
face, the face's part of the edge report (provenance.edge_report) and its display mesh.

Nothing here imports numpy: the reading side never loads it.
"""
import hashlib
from dataclasses import fields

from ...core.exact_keys import derived_key, record_bytes


def record_digest(rec):
    """Digest of a face's record (occ_records.FaceData) without its number and its index
    among the faces sent (part); None for a face sent as OpenCascade's data whose data has
    no digest."""
    if rec.as_data and rec.data_digest is None:
        return None
    return hashlib.sha256(record_bytes([getattr(rec, f.name) for f in fields(rec)
                                        if f.name not in ("number", "part")])).hexdigest()


def area_key(data_digest, occ_version):
    """The store key of OpenCascade's area of a face of digest data_digest of its OpenCascade
    data (the reading process's provenance; the area depends on the face alone)."""
    return derived_key(data_digest, "occ_area", occ_version)


def edges_key(data_digest, number, tol, near):
    """The store key of a face's part of the edge report: the digest of its OpenCascade data
    (data_digest), its number, the tolerance, and near, [(number, data digest)] of the faces
    whose boxes hold its edges' first points."""
    return derived_key(data_digest, "edges", number, tol, [[n, d] for n, d in near])


def display_key(data_digest, deflection, lref_deflection, occ_version, near):
    """The store key of a face's display mesh (record_reader.display_meshes): the digest of
    its OpenCascade data, the display and automatic-L_ref deflections, OpenCascade's
    version, and near, [(whether it comes before the face, data digest)] of the faces that
    share an edge with it."""
    return derived_key(data_digest, "display", deflection, lref_deflection, occ_version, [[b, d] for b, d in near])
