"""The keys of the BRep faces' results in the store (core.result_store).

A face's result depends on its exact geometry and on everything its integration is given:
the reference length and thresholds, the quadrature settings, the face's point budget (its
share of the shape's budget), whether it is integrated alone (in patch groups), the
cross-checks, and the software (this package's source, numpy, its BLAS and the BLAS's
threads, OpenCascade). The key is
two digests: of the geometry (geometry_digest: the face's record, occ_records.FaceData,
without its number, so a face keeps its key when others are added before it) and of the rest
(settings_digest, then face_key with the budget). Both are SHA-256 over an exact encoding
(core.exact_keys: doubles as their 8 bytes, never through text), so equal keys mean equal
inputs bit for bit, and the stored result is the one a fresh integration would give.

A face has two keys (FaceKeys): the exact one, with its point budget, holds a result the
budget bound; the free one, without it, a result the budget never bound, which is the same
to the bit under every budget of at least its budget_needed (cubature.driver), so a face
whose share of the shape's budget changes is still taken from the store where that holds
(face_result.FaceAssessment.fits).
"""
import hashlib
import os
import platform
import sys
from dataclasses import dataclass
from typing import Optional

from ..core import version
from ..core.blas_identity import blas_identity
from ..core.exact_keys import canonical_bytes, derived_key, digest
from .reading.record_keys import record_digest

PACKAGE = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
_FINGERPRINT = None


def software_fingerprint():
    """Digest of what computes a face: this package's version and Python sources, numpy's
    version, the Python version and the machine (made once a process)."""
    global _FINGERPRINT
    if _FINGERPRINT is None:
        import numpy
        h = hashlib.sha256()
        h.update(canonical_bytes([version.__version__, numpy.__version__, list(sys.version_info[:2]), platform.machine()]))
        for root, dirs, files in os.walk(PACKAGE):
            dirs[:] = sorted(d for d in dirs if d != "__pycache__")
            for name in sorted(files):
                if name.endswith(".py"):
                    path = os.path.join(root, name)
                    h.update(os.path.relpath(path, PACKAGE).encode())
                    with open(path, "rb") as fh:
                        h.update(fh.read())
        _FINGERPRINT = h.hexdigest()
    return _FINGERPRINT


def geometry_digest(face):
    """record_digest of a face: a recorded_shape.FaceRecord's record, or a Part.Face's made
    here (occ_records.face_record, else the record of its data); None when it has none."""
    rec = getattr(face, "rec", None)
    if rec is None:
        from .reading.occ_records import face_record
        from .reading.record_reader import part_record
        try:
            rec, why = face_record(face, 0, 0)
            if rec is None:
                rec = part_record(face, why, 0, 0)
        except Exception:  # OpenCascade cannot describe the face: it is integrated, never stored
            return None
    return record_digest(rec)


def settings_digest(lref, thresholds, opts, alone, cross_checks, occ_version, reading):
    """Digest of what every face of a run is integrated with: L_ref, the thresholds (tau_H,
    tau_K), the quadrature options (budget.QuadratureOptions) but the shape's point budget (a
    face's result depends on its own budget alone: face_keys), whether a face is integrated
    alone (in patch groups), the cross-checks, OpenCascade's version, how the faces were
    read (the run's kind), the software_fingerprint and numpy's BLAS with its threads
    (core.blas_identity: they set the last bits of the matrix products)."""
    quadrature = sorted((k, v) for k, v in opts.record().items() if k != "point_budget")
    return digest([software_fingerprint(), float(lref), float(thresholds.tau_H), float(thresholds.tau_K),
                   quadrature, bool(alone), bool(cross_checks), occ_version, reading, blas_identity()])


#: What stands for the budget in a face's free key.
ANY_BUDGET = "any point budget from the result's budget_needed on"


@dataclass(frozen=True)
class FaceKeys:
    """A face's keys in the store: exact (face_key with its point budget), free (face_key
    with ANY_BUDGET; None without a budget), and the budget."""

    exact: str
    free: Optional[str]
    budget: Optional[int]

    @property
    def claim(self):
        """The key a run claims while it makes the face (core.result_claims): the free one
        where there is one, so that runs giving the face other budgets make it once too."""
        return self.free or self.exact


def face_keys(geometry, settings, budget):
    """FaceKeys of a face of geometry digest geometry, integrated with settings within budget
    points (None: no limit)."""
    return FaceKeys(face_key(geometry, settings, budget),
                    None if budget is None else face_key(geometry, settings, ANY_BUDGET), budget)


def face_key(geometry, settings, budget):
    """The store key of a face of geometry digest geometry, integrated with settings
    (settings_digest) within budget points (None: no limit): the geometry's first HALF
    digits, then HALF of the rest's."""
    return derived_key(geometry, settings, budget)


def display_samples_key(geometry, mesh, reading):
    """The store key of a face's display samples (display.face_display_mesh): the exact
    fields at the nodes of its display mesh (occ_records.display_mesh: points, triangles and
    (u, v)) depend on its geometry, the mesh, how the face was read (the run's kind: which
    evaluation its field uses) and the software alone."""
    return derived_key(digest(["display samples", geometry]), software_fingerprint(), reading, list(mesh))
