"""Reference length L_ref (paper eq:refs): explicit, or automatic from the surface.

The automatic length is the span of the surface along its first principal axis, computed
from the exact area moments of a triangulation of it (a BRep's coarse tessellation, or
the mesh itself), stated to AUTOMATIC_DIGITS significant digits. It approximates the overall
length of the represented surface; for a hull it is close to, but not the same as, L_pp.
A coarse tessellation does not give the span to more digits, and an edit that leaves the
hull's length alone (a pole moved on the bilge) leaves the stated length alone too, so the
faces it did not touch keep their thresholds and their stored results (brep.face_keys).
"""
from dataclasses import dataclass

import numpy as np

from .constants import LREF_PLAUSIBLE_RATIO
from .errors import InputError
from .threads import blocks, default_threads, run_blocks
from .thresholds import check_positive

#: Significant digits of the automatic L_ref (a relative step of at most 5e-6: I_D moves by at
#: most 1e-5 of itself, a tenth of the default tolerance).
AUTOMATIC_DIGITS = 6
AUTOMATIC_METHOD = ("principal-axis span: extent of the triangulated surface along the first principal axis of "
                    "its area (exact area moments of the triangles), to %d significant digits" % AUTOMATIC_DIGITS)


def principal_axis_span(points, triangles, node_area=None, triangle_area=None):
    """Extent of points (n, 3) along the first principal axis of the triangulated surface
    (triangles (m, 3) indices into points): the axis of largest variance of the area measure
    over the triangles, from its exact moments, integral of x dA = sum_t A_t s_t / 3 and
    integral of x x^T dA = sum_t A_t / 12 (sum of v v^T over the corners + s_t s_t^T), s_t the
    sum of triangle t's corners. The moments do not depend on how a plane region is cut
    into triangles. node_area (sum of A_t / 3 at each node) and triangle_area (A_t): the
    areas when at hand."""
    P = np.asarray(points, dtype=float).reshape(-1, 3)
    T = np.asarray(triangles, dtype=np.int64).reshape(-1, 3)
    f = np.isfinite(P)
    finite = f[:, 0] & f[:, 1] & f[:, 2]
    del f
    if np.count_nonzero(finite) < 2:
        raise InputError("cannot derive a reference length: fewer than two finite surface points")
    all_finite = bool(finite.all())
    if all_finite:
        X = P - P.mean(0)
    else:
        X = np.where(finite[:, None], P - P[finite].mean(0), 0.0)
        T = T[finite[T[:, 0]] & finite[T[:, 1]] & finite[T[:, 2]]]
        node_area = triangle_area = None
    s = np.empty((len(T), 3))       # s_t, the sum of the corners
    area = np.empty(len(T)) if triangle_area is None else np.asarray(triangle_area, dtype=float)
    corners = [np.ascontiguousarray(T[:, k]) for k in range(3)]

    def block(sl):
        a, b, c = (np.take(X, corners[k][sl], axis=0) for k in range(3))
        if triangle_area is None:
            area[sl] = _triangle_areas(a, b, c)
        a += b
        a += c
        s[sl] = a
    run_blocks(block, blocks(len(T), BLOCK), default_threads())
    total = area.sum()
    if not total > 0:  # no area: the points' own spread
        Y = X[finite] - X[finite].mean(0)
        cov = Y.T @ Y
    else:
        if node_area is None:
            node_area = np.bincount(T.ravel(), weights=np.repeat(area / 3.0, 3), minlength=len(P))
        wX = np.asarray(node_area, dtype=float)[:, None] * X
        second = 0.25 * (wX.T @ X) + (s.T @ (s * area[:, None])) / 12.0
        mean = wX.sum(0) / total
        cov = second / total - np.outer(mean, mean)
    _, vecs = np.linalg.eigh(cov)
    along = (X if all_finite else X[finite]) @ vecs[:, -1]
    return float(along.max() - along.min())


def automatic_length(points, triangles, node_area=None, triangle_area=None):
    """The automatic L_ref: principal_axis_span to AUTOMATIC_DIGITS significant digits."""
    return float("%.*g" % (AUTOMATIC_DIGITS, principal_axis_span(points, triangles, node_area, triangle_area)))


#: Triangles a block of the corner sums.
BLOCK = 1 << 15


def _triangle_areas(a, b, c):
    """(b,) areas |(b - a) x (c - a)| / 2 of the triangles of corners a, b, c (b, 3)."""
    e1, e2 = b - a, c - a
    return 0.5 * np.sqrt((e1[:, 1] * e2[:, 2] - e1[:, 2] * e2[:, 1]) ** 2
                         + (e1[:, 2] * e2[:, 0] - e1[:, 0] * e2[:, 2]) ** 2
                         + (e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]) ** 2)


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


def resolve_reference_length(points, triangles, node_area=None, explicit=None, units="", triangle_area=None):
    """Choose L_ref: the explicit value when given (checked > 0), else the automatic span
    of the triangulated surface (automatic_length).

    When explicit, the automatic span is still computed and a warning is recorded if the
    ratio of the two lies outside [1/10, 10].
    """
    auto = automatic_length(points, triangles, node_area, triangle_area)
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
