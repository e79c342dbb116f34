"""Reference length L_ref (paper eq:refs): explicit, or automatic from the surface.

The automatic length is the span of the surface along its first principal axis,
computed from area-weighted surface samples. It approximates the overall length of the
represented surface; for a hull it is close to, but not the same as, L_pp.
"""
from dataclasses import dataclass

import numpy as np

from .constants import LREF_PLAUSIBLE_RATIO
from .errors import InputError
from .thresholds import check_positive

AUTOMATIC_METHOD = "principal-axis span: extent of the area-weighted surface samples along their first principal axis"


def principal_axis_span(points, weights=None):
    """Extent of points (n, 3) along the principal axis of largest weighted variance."""
    P = np.asarray(points, dtype=float).reshape(-1, 3)
    P = P[np.all(np.isfinite(P), axis=1)]
    if len(P) < 2:
        raise InputError("cannot derive a reference length: fewer than two finite surface points")
    w = np.ones(len(P)) if weights is None else np.asarray(weights, dtype=float).reshape(-1)[: len(P)]
    w = np.where(np.isfinite(w) & (w > 0), w, 0.0)
    if w.sum() <= 0:
        w = np.ones(len(P))
    c = (w[:, None] * P).sum(0) / w.sum()
    X = P - c
    cov = (w[:, None] * X).T @ X / w.sum()
    _, vecs = np.linalg.eigh(cov)
    axis = vecs[:, -1]
    s = X @ axis
    return float(s.max() - s.min())


@dataclass
class ReferenceLength:
    """The L_ref used, how it was chosen, and the automatic proposal for comparison."""

    value: float
    mode: str                  # 'explicit' | 'automatic'
    method: str
    automatic_value: float
    warning: str = ""

    def to_dict(self):
        return {"value": self.value, "mode": self.mode, "method": self.method,
                "automatic_value": self.automatic_value, "plausibility_warning": self.warning or None}


def resolve_reference_length(points, weights=None, explicit=None, units=""):
    """Choose L_ref: the explicit value when given (checked > 0), else the automatic span.

    When explicit, the automatic span is still computed and a warning is recorded if the
    ratio of the two lies outside [1/10, 10].
    """
    auto = principal_axis_span(points, weights)
    if auto <= 0:
        raise InputError("cannot derive a reference length: the surface has zero extent")
    if explicit is None:
        return ReferenceLength(auto, "automatic", AUTOMATIC_METHOD, auto)
    value = check_positive("reference length L_ref", explicit)
    ratio = value / auto
    warning = ""
    if not (1.0 / LREF_PLAUSIBLE_RATIO <= ratio <= LREF_PLAUSIBLE_RATIO):
        u = (" " + units) if units else ""
        warning = ("explicit L_ref = %g%s is %.3g times the surface's principal-axis span %g%s: "
                   "check the units" % (value, u, ratio, auto, u))
    return ReferenceLength(value, "explicit", "given by the user", auto, warning)
