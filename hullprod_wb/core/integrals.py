"""Surface integrals from which the signature is formed.

Both backends reduce to the same handful of integrals over the represented surface:
represented area A, valid Gaussian-curvature area A_K, integral of |K|, max(K,0),
max(-K,0) over the valid domain, and the four class areas (paper eq:dev, eq:devsigned,
eq:classes). The mesh backend forms them as vertex-area weighted sums (eq:mesh_ID); the
BRep backend by adaptive quadrature (eq:brep_surface_integral).
"""
from dataclasses import dataclass, field

import numpy as np

from .constants import CLASS_NAMES
from .thresholds import classify


@dataclass
class SurfaceIntegrals:
    """Integrals over the represented surface (dimensional, before normalisation).

    represented_area: A, area of everything represented (m^2 or mm^2, the input's units).
    valid_area: A_K, area where K is defined and integrable.
    int_abs_K, int_K_plus, int_K_minus: integrals of |K|, max(K,0), max(-K,0) dA over A_K.
    class_areas: (4,) areas of flat, single, elliptic, saddle (eq:curvature_classes).
    """

    represented_area: float
    valid_area: float
    int_abs_K: float
    int_K_plus: float
    int_K_minus: float
    class_areas: np.ndarray = field(default_factory=lambda: np.zeros(4))

    @property
    def classified_area(self):
        """A_C, the valid classified area (denominator of eq:classes)."""
        return float(np.sum(self.class_areas))

    def __add__(self, other):
        return SurfaceIntegrals(
            self.represented_area + other.represented_area,
            self.valid_area + other.valid_area,
            self.int_abs_K + other.int_abs_K,
            self.int_K_plus + other.int_K_plus,
            self.int_K_minus + other.int_K_minus,
            np.asarray(self.class_areas, float) + np.asarray(other.class_areas, float),
        )

    @classmethod
    def zero(cls):
        return cls(0.0, 0.0, 0.0, 0.0, 0.0, np.zeros(4))

    def to_dict(self):
        return {
            "represented_area": float(self.represented_area),
            "valid_area": float(self.valid_area),
            "int_abs_K": float(self.int_abs_K),
            "int_K_plus": float(self.int_K_plus),
            "int_K_minus": float(self.int_K_minus),
            "class_areas": {n: float(a) for n, a in zip(CLASS_NAMES, self.class_areas)},
        }


def integrals_from_samples(K, H, weights, valid, tau_H, tau_K, represented_weights=None):
    """Weighted-sum integrals of sampled curvature (eq:mesh_ID and its signed analogues).

    K, H, weights: (n,) float (weights are the areas A_i of eq:vertex_area); valid: (n,)
    bool, the samples in the valid K domain. represented_weights defaults to weights and
    gives the represented area (boundary samples count there, not in A_K).
    """
    K = np.asarray(K, dtype=float)
    H = np.asarray(H, dtype=float)
    w = np.asarray(weights, dtype=float)
    ok = np.asarray(valid, dtype=bool) & np.isfinite(K) & np.isfinite(H)
    wk = np.where(ok, w, 0.0)
    Kv = np.where(ok, K, 0.0)
    cls = classify(K, H, tau_H, tau_K, ok)
    inside = cls >= 0
    class_areas = np.bincount(cls[inside], weights=w[inside], minlength=4).astype(float)
    rep = w if represented_weights is None else np.asarray(represented_weights, dtype=float)
    return SurfaceIntegrals(
        represented_area=float(rep.sum()),
        valid_area=float(wk.sum()),
        int_abs_K=float(np.dot(wk, np.abs(Kv))),
        int_K_plus=float(np.dot(wk, np.maximum(Kv, 0.0))),
        int_K_minus=float(np.dot(wk, np.maximum(-Kv, 0.0))),
        class_areas=class_areas,
    )
