"""Distributed surface fields q_D, q_D+, q_D-, class, H, K (paper eq:devfield,
eq:devsignedfields, eq:curvature_classes).

For a mesh the samples are the mesh vertices with their barycentric areas; for a BRep
they are exact samples at the nodes of a display-only tessellation (never used in the
integrals).
"""
from dataclasses import dataclass, field

import numpy as np

from .thresholds import classify


@dataclass
class DistributedFields:
    """Sampled curvature on a triangulated carrier.

    points: (n, 3) float; triangles: (m, 3) int; K, H: (n,) float; valid: (n,) bool
    (samples in the valid K domain); weights: (n,) float associated areas or None
    (display-only samples); kind: 'mesh-vertex' | 'brep-display'; extra: further
    (n,) point arrays exported alongside (e.g. k1, k2, face id).
    """

    points: np.ndarray
    triangles: np.ndarray
    K: np.ndarray
    H: np.ndarray
    valid: np.ndarray
    lref: float
    tau_H: float
    tau_K: float
    weights: object = None
    kind: str = "mesh-vertex"
    extra: dict = field(default_factory=dict)

    def _masked(self, x):
        return np.where(self.valid & np.isfinite(self.K), x, np.nan)

    @property
    def q_D(self):
        """|K| L_ref^2 (eq:devfield); NaN where invalid."""
        return self._masked(np.abs(self.K) * self.lref ** 2)

    @property
    def q_D_plus(self):
        """max(K, 0) L_ref^2 (eq:devsignedfields); NaN where invalid."""
        return self._masked(np.maximum(self.K, 0.0) * self.lref ** 2)

    @property
    def q_D_minus(self):
        """max(-K, 0) L_ref^2 (eq:devsignedfields); NaN where invalid."""
        return self._masked(np.maximum(-self.K, 0.0) * self.lref ** 2)

    @property
    def class_id(self):
        """-1 invalid, 0 flat, 1 single, 2 elliptic, 3 saddle (eq:curvature_classes)."""
        return classify(self.K, self.H, self.tau_H, self.tau_K, self.valid)

    def point_arrays(self):
        """Ordered name -> (n,) array mapping of everything exported per point."""
        out = {
            "q_D": self.q_D,
            "q_D_plus": self.q_D_plus,
            "q_D_minus": self.q_D_minus,
            "class_id": self.class_id.astype(np.int32),
            "H": np.asarray(self.H, float),
            "K": np.asarray(self.K, float),
            "valid": np.asarray(self.valid, dtype=np.uint8),
        }
        if self.weights is not None:
            out["area"] = np.asarray(self.weights, float)
        for k, v in self.extra.items():
            out[k] = np.asarray(v)
        return out
