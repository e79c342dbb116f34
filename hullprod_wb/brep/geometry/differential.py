"""Pointwise differential geometry of a parametric surface from its derivatives.

Given S_u, S_v, S_uu, S_uv, S_vv at n points (each (n, 3) float):

    E = S_u.S_u, F = S_u.S_v, G = S_v.S_v, D = EG - F^2          (eq:brep_first_form)
    J = |S_u x S_v| = sqrt(D)                                     (eq:brep_jacobian)
    n = s (S_u x S_v) / J,  s = +1 Forward, -1 Reversed face      (eq:brep_normal)
    e = n.S_uu, f = n.S_uv, g = n.S_vv                            (eq:brep_second_form)
    H = (eG - 2fF + gE) / (2D),  K = (eg - f^2) / D               (eq:brephk)
    k1,2 = H +- sqrt(max(H^2 - K, 0)),  k1 >= k2

D and J are taken from the cross product (Lagrange's identity |S_u x S_v|^2 = EG - F^2),
which does not lose digits to cancellation near degenerate points. H (and k1, k2) change
sign with the orientation s; K does not.

A point is ``regular`` when every input is finite and J > eps * scale, with the scale
max(E, G) by default (so both a vanishing tangent, e.g. at a sphere pole or a collapsed
pole row, and parallel tangents are caught: J / max(E, G) = sin(angle) * min|S_.| / max|S_.|),
or a caller-given reference value of |S_u||S_v|. At non-regular points the normal and all
curvature quantities are NaN; E, F, G, D, J stay as computed.

Given bounds r of the rounding of the derivatives (r_u, r_v, r_uu, r_uv, r_vv, absolute,
nurbs.NurbsSurfaceData.rounding) and a curvature scale c of the surface (the
Gaussian curvature 1 / R^2 of a sphere of its poles' size), K is zero where |K| is within
its own rounding bound b (k_rounding_bound), b <= c, and the point is nearly developable
(|K| <= NEAR_DEVELOPABLE (k1^2 + k2^2), k1^2 + k2^2 = 4 H^2 - 2 K): a developable face (a
plate, a cylinder or cone as a B-spline) then has K = 0 instead of noise of either sign,
which no refinement reduces. Where b exceeds the surface's own curvature scale (towards a
collapsed side, where J -> 0 and the normal's rounding is large), K keeps its computed
value: it is not known to be zero there, only not known.
"""
from typing import NamedTuple, Optional

import numpy as np

from ...core.errors import InputError

#: Default relative threshold on J for the regularity test (see module docstring).
DEFAULT_DEGENERACY_EPS = 1e-10
#: K counts as zero to rounding only at nearly developable points, |K| <= NEAR_DEVELOPABLE
#: (k1^2 + k2^2) (module doc): where K's rounding bound is larger than that, the curvatures
#: themselves are not resolved.
NEAR_DEVELOPABLE = 1e-6


class SurfaceDifferentials(NamedTuple):
    """First/second fundamental forms and curvatures at n points (arrays (n,) unless noted)."""

    E: np.ndarray
    F: np.ndarray
    G: np.ndarray
    D: np.ndarray
    J: np.ndarray
    normal: np.ndarray          # (n, 3), oriented unit normal, NaN where not regular
    e: np.ndarray
    f: np.ndarray
    g: np.ndarray
    H: np.ndarray
    K: np.ndarray
    k1: np.ndarray              # k1 >= k2
    k2: np.ndarray
    regular: np.ndarray         # (n,) bool
    dir1: Optional[np.ndarray]  # (n, 3) unit principal direction of k1, or None
    dir2: Optional[np.ndarray]  # (n, 3) unit principal direction of k2 (= n x dir1), or None


def _dot(a, b):
    return np.einsum("ij,ij->i", a, b)


def _cross(a, b):
    out = np.empty_like(a)
    out[:, 0] = a[:, 1] * b[:, 2] - a[:, 2] * b[:, 1]
    out[:, 1] = a[:, 2] * b[:, 0] - a[:, 0] * b[:, 2]
    out[:, 2] = a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]
    return out


def _check(name, a, n=None):
    a = np.asarray(a, dtype=float)
    if a.ndim != 2 or a.shape[1] != 3 or (n is not None and a.shape[0] != n):
        raise InputError("%s must be an (n, 3) array%s, got shape %s"
                         % (name, "" if n is None else " with n = %d" % n, a.shape))
    return a


def _components(a):
    """The x, y, z rows (3, n) of an (n, 3) array, contiguous: the arithmetic below then
    runs on contiguous arrays, one pass per operation, instead of strided columns."""
    return np.ascontiguousarray(a.T)


def _cross_rows(a, b):
    """a x b (3, n) of two vector fields given as their x, y, z rows (3, n)."""
    (ax, ay, az), (bx, by, bz) = a, b
    c = np.empty(a.shape)
    np.subtract(ay * bz, az * by, out=c[0])
    np.subtract(az * bx, ax * bz, out=c[1])
    np.subtract(ax * by, ay * bx, out=c[2])
    return c


def jacobian(su, sv):
    """Area element J = |S_u x S_v| (eq:brep_jacobian), (n,) float from two (n, 3) arrays."""
    c = _cross_rows(_components(_check("Su", su)), _components(_check("Sv", sv)))
    return np.sqrt(c[0] * c[0] + c[1] * c[1] + c[2] * c[2])


class CurvatureFields(NamedTuple):
    """What the cubature needs at n points: J, K, H (n,) and regular (n,) bool, with the
    first and second fundamental forms and the oriented unit normal's components (3, n)
    (NaN where not regular) that they come from."""

    E: np.ndarray
    F: np.ndarray
    G: np.ndarray
    D: np.ndarray
    J: np.ndarray
    normal_xyz: np.ndarray
    e: np.ndarray
    f: np.ndarray
    g: np.ndarray
    H: np.ndarray
    K: np.ndarray
    regular: np.ndarray


def _derivative_arrays(derivatives):
    """(Su, Sv, Suu, Suv, Svv), each checked (n, 3), of derivatives with or without S."""
    if len(derivatives) == 6:
        derivatives = derivatives[1:]
    if len(derivatives) != 5:
        raise InputError("expected (S, Su, Sv, Suu, Suv, Svv) or (Su, Sv, Suu, Suv, Svv), got %d arrays"
                         % len(derivatives))
    su = _check("Su", derivatives[0])
    n = su.shape[0]
    return (su,) + tuple(_check(name, a, n) for name, a in zip(("Sv", "Suu", "Suv", "Svv"), derivatives[1:]))


def curvature_fields(derivatives, orientation_sign=1, eps=DEFAULT_DEGENERACY_EPS, scale=None, rounding=None):
    """Fundamental forms, J, H, K and regularity at n points (the module doc's formulas),
    computed on the x, y, z components; derivatives, orientation_sign, eps and scale as for
    surface_differentials, which adds the normal as (n, 3) vectors and the principal
    curvatures; rounding None or (r_of, c): r_of(i) the derivatives' rounding bounds
    (len(i), 5) at the points of indices i, c the surface's curvature scale; K is set to zero
    within k_rounding_bound where that is at most c at nearly developable points (module doc).
    Returns a CurvatureFields."""
    if orientation_sign not in (1, -1):
        raise InputError("orientation_sign must be +1 or -1, got %r" % (orientation_sign,))
    su, sv, suu, suv, svv = (_components(a) for a in _derivative_arrays(derivatives))
    n = su.shape[1]
    (ux, uy, uz), (vx, vy, vz) = su, sv
    E = ux * ux + uy * uy + uz * uz
    F = ux * vx + uy * vy + uz * vz
    G = vx * vx + vy * vy + vz * vz
    c = _cross_rows(su, sv)
    D = c[0] * c[0] + c[1] * c[1] + c[2] * c[2]
    J = np.sqrt(D)
    ref = np.maximum(E, G) if scale is None else np.broadcast_to(np.asarray(scale, dtype=float), (n,))
    with np.errstate(invalid="ignore"):
        regular = (J > eps * ref) & np.isfinite(J) & np.isfinite(E) & np.isfinite(G)
        regular &= np.isfinite(suu).all(axis=0) & np.isfinite(suv).all(axis=0) & np.isfinite(svv).all(axis=0)
    with np.errstate(divide="ignore", invalid="ignore"):
        inv_j = np.where(regular, float(orientation_sign) / np.where(regular, J, 1.0), np.nan)
        normal = c * inv_j
        nx, ny, nz = normal
        e = nx * suu[0] + ny * suu[1] + nz * suu[2]
        f = nx * suv[0] + ny * suv[1] + nz * suv[2]
        g = nx * svv[0] + ny * svv[1] + nz * svv[2]
        inv_d = np.where(regular, 1.0 / np.where(regular, D, 1.0), np.nan)
        H = (e * G - 2.0 * f * F + g * E) * (0.5 * inv_d)
        K = (e * g - f * f) * inv_d
        if rounding is not None:  # the candidates: |K| <= c at nearly developable points
            r_of, scale_K = rounding
            aK = np.abs(K)
            i = np.nonzero((aK <= scale_K) & (aK <= NEAR_DEVELOPABLE * np.abs(4.0 * H * H - 2.0 * K)))[0]
            if i.size:
                b = k_rounding_bound(E[i], G[i], J[i], e[i], f[i], g[i], suu[:, i], suv[:, i], svv[:, i], r_of(i))
                K[i[(aK[i] <= b) & (b <= scale_K)]] = 0.0
    return CurvatureFields(E, F, G, D, J, normal, e, f, g, H, K, regular)


def k_rounding_bound(E, G, J, e, f, g, suu, suv, svv, r):
    """Bound of the rounding of K = (eg - f^2) / D from the derivatives' rounding bounds r
    (n, 5) (r_u, r_v, r_uu, r_uv, r_vv), to first order and with the products of the
    second form's errors: the unit normal is within nu = (3 eps |S_u||S_v| + r_u |S_v| +
    |S_u| r_v) / J + 3 eps (cross product, normalisation, dot products), so de = r_uu +
    nu |S_uu| (df, dg likewise), and
    |dK| <= (|g| de + |e| dg + 2 |f| df + de dg + df^2 + 2 eps (|eg| + f^2)) / D.
    suu, suv, svv: x, y, z rows (3, n). Returns (n,) float."""
    ulp = np.finfo(float).eps
    r = np.asarray(r, dtype=float).T
    su, sv = np.sqrt(E), np.sqrt(G)
    nu = (3.0 * ulp * su * sv + r[0] * sv + su * r[1]) / J + 3.0 * ulp
    de = r[2] + nu * np.sqrt((suu * suu).sum(0))
    df = r[3] + nu * np.sqrt((suv * suv).sum(0))
    dg = r[4] + nu * np.sqrt((svv * svv).sum(0))
    ae, af, ag = np.abs(e), np.abs(f), np.abs(g)
    return (ag * de + ae * dg + 2.0 * af * df + de * dg + df * df + 2.0 * ulp * (ae * ag + af * af)) / (J * J)


def principal_curvatures(H, K):
    """k1 >= k2 = H +- sqrt(max(H^2 - K, 0))."""
    with np.errstate(invalid="ignore"):
        disc = np.sqrt(np.maximum(H * H - K, 0.0))
    return H + disc, H - disc


def surface_differentials(derivatives, orientation_sign=1, eps=DEFAULT_DEGENERACY_EPS, scale=None,
                          directions=False, rounding=None):
    """Fundamental forms, normal, H, K and principal curvatures at n points.

    derivatives: (S, Su, Sv, Suu, Suv, Svv) or (Su, Sv, Suu, Suv, Svv), each (n, 3) float.
    orientation_sign: +1 (Forward face) or -1 (Reversed face).
    eps, scale: regular iff J > eps * scale; scale None means max(E, G) per point, else a
        scalar or (n,) reference magnitude of |S_u||S_v|.
    directions: also return the principal directions (unit (n, 3) vectors in 3-D).
    rounding: None or the derivatives' rounding bounds and curvature scale (curvature_fields).
    Returns a SurfaceDifferentials.
    """
    c = curvature_fields(derivatives, orientation_sign, eps, scale, rounding)
    normal = c.normal_xyz.T
    k1, k2 = principal_curvatures(c.H, c.K)
    dir1 = dir2 = None
    if directions:
        su, sv = _derivative_arrays(derivatives)[:2]
        dir1, dir2 = _principal_directions(su, sv, normal, c.E, c.F, c.G, c.e, c.f, c.g, k1, k2)
    return SurfaceDifferentials(c.E, c.F, c.G, c.D, c.J, normal, c.e, c.f, c.g, c.H, c.K, k1, k2,
                                c.regular, dir1, dir2)


def _principal_directions(su, sv, normal, E, F, G, e, f, g, k1, k2):
    """Unit principal directions (dir1 for k1, dir2 = n x dir1), each (n, 3).

    The symmetric singular matrix II - k1 I = [[a, b], [b, c]] annihilates (-b, a) and (c, -b)
    in (du, dv); the one with the longer 3-D image du S_u + dv S_v is used. At umbilics
    (|a|, |b|, |c| <= 1e-14 (|k1| + |k2|) max(E, G), including planar points) every tangent
    is principal and dir1 = S_u / |S_u|.
    """
    a, b, c = e - k1 * E, f - k1 * F, g - k1 * G
    t_a = (-b)[:, None] * su + a[:, None] * sv
    t_b = c[:, None] * su + (-b)[:, None] * sv
    la, lb = _dot(t_a, t_a), _dot(t_b, t_b)
    t = np.where((la >= lb)[:, None], t_a, t_b)
    size = np.maximum(np.maximum(np.abs(a), np.abs(b)), np.abs(c))
    umbilic = size <= 1e-14 * (np.abs(k1) + np.abs(k2)) * np.maximum(E, G)
    t = np.where(umbilic[:, None], su, t)
    t = t - _dot(t, normal)[:, None] * normal  # exact tangent (removes rounding)
    with np.errstate(divide="ignore", invalid="ignore"):
        t = t / np.sqrt(_dot(t, t))[:, None]
    return t, _cross(normal, t)
