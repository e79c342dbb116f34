"""The parameter region of a same-face grid (paper section 5.2): the inset rectangle of an
untrimmed face, the largest axis-parallel rectangle inside a trimmed domain, and the
midpoint estimate of a face's integral of |K| dA on the same raster. See :mod:`.sameface`."""
import numpy as np

from ..core.errors import InputError
from .sameface_grid import DEFAULT_INSET, RASTER, SAMEFACE_LEVELS, grid_parameters


# ---------------------------------------------------------------------------------------------
# the parameter rectangle


def _inside_function(face):
    """Vectorised inside(u, v) -> bool for the face's trimmed domain, and its description.

    Uses the exact trimmed domain (p-curves); when it cannot be built, OpenCascade's
    per-point face classifier (Part.Face.isPartOfDomain).
    """
    from ..brep.geometry.trimmed_domain import TrimmedDomain
    try:
        domain = TrimmedDomain.from_face(face)
    except InputError as exc:
        def inside_occ(u, v):
            u = np.asarray(u, float).ravel()
            v = np.asarray(v, float).ravel()
            return np.array([bool(face.isPartOfDomain(float(a), float(b))) for a, b in zip(u, v)])
        return inside_occ, False, "OpenCascade face classifier (trim curves unusable: %s)" % exc

    def inside(u, v):
        u = np.asarray(u, float).ravel()
        v = np.asarray(v, float).ravel()
        out = np.zeros(u.size, dtype=bool)
        idx, lo, hi = domain.v_intervals(u)
        if idx.size:
            hit = (v[idx] >= lo) & (v[idx] <= hi)
            out[idx[hit]] = True
        return out
    return inside, bool(domain.is_rectangle), "trim-curve domain"


def largest_rectangle(grid):
    """Largest all-True axis-parallel rectangle of a (r, c) bool raster.

    Returns (i0, i1, j0, j1), inclusive row and column ranges, or None. Row-by-row
    maximal rectangle under a histogram (stack method), O(r c).
    """
    r, c = grid.shape
    heights = np.zeros(c, dtype=int)
    best, box = 0, None
    for i in range(r):
        heights = np.where(grid[i], heights + 1, 0)
        stack = []
        for j in range(c + 1):
            h = heights[j] if j < c else 0
            start = j
            while stack and stack[-1][1] >= h:
                start, hs = stack.pop()
                area = hs * (j - start)
                if area > best:
                    best, box = area, (i - hs + 1, i, start, j - 1)
            stack.append((start, h))
    return box


def inset_rectangle(face, inset=DEFAULT_INSET, check_levels=SAMEFACE_LEVELS, creases=None, inside=None):
    """Parameter rectangle of the same-face grids for a Part.Face (see module docstring).

    creases: None or a callable rect -> (u_creases, v_creases) whose lines the checked grids
    place on grid lines (:func:`grid_parameters`). inside: the face's
    :func:`_inside_function` result when already built. Returns dict(rect (u0, u1, v0, v1),
    base_rect, trimmed, method, inset, checked_levels (the levels whose grids fit: crease
    lines placed and, on a trimmed face, every vertex inside the trimmed domain),
    level_reasons {level: why it does not fit}). Raises InputError when no rectangle inside
    the trimmed domain is found.
    """
    if not 0.0 <= float(inset) < 0.5:
        raise InputError("the inset must be a fraction in [0, 0.5), got %r" % (inset,))
    U0, U1, V0, V1 = (float(x) for x in face.ParameterRange)
    if not (U1 > U0 and V1 > V0):
        raise InputError("the face has an empty parameter range %r" % ((U0, U1, V0, V1),))
    inside, is_rect, how = inside or _inside_function(face)
    if is_rect:
        base = (U0, U1, V0, V1)
        method = "untrimmed face: parameter range"
    else:
        du, dv = (U1 - U0) / RASTER, (V1 - V0) / RASTER
        uc, vc = grid_parameters((U0 + du / 2, U1 - du / 2, V0 + dv / 2, V1 - dv / 2), RASTER - 1)
        raster = inside(uc, vc).reshape(RASTER, RASTER)
        box = largest_rectangle(raster)
        if box is None:
            raise InputError("no parameter rectangle found inside the face's trimmed domain (no raster "
                             "cell of %dx%d inside)" % (RASTER, RASTER))
        if box[1] - box[0] < 2 or box[3] - box[2] < 2:
            raise InputError("the largest parameter rectangle inside the face's trimmed domain is too thin: "
                             "%d x %d cells of a %dx%d raster (at least 3 x 3 needed)"
                             % (box[1] - box[0] + 1, box[3] - box[2] + 1, RASTER, RASTER))
        i0, i1, j0, j1 = box
        # raster cells i0..i1 cover [U0 + i0 du, U0 + (i1+1) du]; drop one cell each side
        base = (U0 + (i0 + 1) * du, U0 + i1 * du, V0 + (j0 + 1) * dv, V0 + j1 * dv)
        method = "trimmed face: largest rectangle inside the %s" % how
    u0, u1, v0, v1 = base
    rect = (u0 + inset * (u1 - u0), u1 - inset * (u1 - u0), v0 + inset * (v1 - v0), v1 - inset * (v1 - v0))
    lines = None if creases is None else creases(rect)
    checked, why = [], {}
    for n in check_levels:
        try:
            u, v = grid_parameters(rect, n, lines)
        except InputError as exc:
            why[n] = str(exc)
            continue
        if not is_rect:
            out = int((~inside(u, v)).sum())
            if out:
                why[n] = ("%d of the %d vertices of the %dx%d grid over the inset rectangle lie outside the "
                          "trimmed domain" % (out, u.size, n, n))
                continue
        checked.append(n)
    return {"rect": rect, "base_rect": base, "trimmed": not is_rect, "method": method,
            "inset": float(inset), "checked_levels": checked, "level_reasons": why}


def abs_K_integral(face, evaluator, inside, m=RASTER):
    """Midpoint estimate of the integral of |K| dA over the face's trimmed domain: the m x m
    cells of its parameter range whose centres are inside and regular (the raster of
    :func:`inset_rectangle`); None when there are none."""
    from ..brep.geometry.differential import surface_differentials
    U0, U1, V0, V1 = (float(x) for x in face.ParameterRange)
    du, dv = (U1 - U0) / m, (V1 - V0) / m
    uc, vc = grid_parameters((U0 + du / 2, U1 - du / 2, V0 + dv / 2, V1 - dv / 2), m - 1)
    keep = np.ones(uc.size, dtype=bool) if inside[1] else inside[0](uc, vc)
    if not keep.any():
        return None
    d = surface_differentials(evaluator.derivatives(uc[keep], vc[keep]), evaluator.orientation_sign)
    ok = d.regular & np.isfinite(d.K) & np.isfinite(d.J)
    if not ok.any():
        return None
    return float(np.sum(np.abs(d.K[ok]) * d.J[ok]) * du * dv)
