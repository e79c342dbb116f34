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
"""
from typing import NamedTuple, Optional

import numpy as np

from ..core.errors import InputError

#: Default relative threshold on J for the regularity test (see module docstring).
DEFAULT_DEGENERACY_EPS = 1e-10


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


def jacobian(su, sv):
    """Area element J = |S_u x S_v| (eq:brep_jacobian), (n,) float from two (n, 3) arrays."""
    su, sv = _check("Su", su), _check("Sv", sv)
    c = _cross(su, sv)
    return np.sqrt(_dot(c, c))


def surface_differentials(derivatives, orientation_sign=1, eps=DEFAULT_DEGENERACY_EPS, scale=None,
                          directions=False):
    """Fundamental forms, normal, H, K and principal curvatures at n points.

    derivatives: (S, Su, Sv, Suu, Suv, Svv) or (Su, Sv, Suu, Suv, Svv), each (n, 3) float.
    orientation_sign: +1 (Forward face) or -1 (Reversed face).
    eps, scale: regular iff J > eps * scale; scale None means max(E, G) per point, else a
        scalar or (n,) reference magnitude of |S_u||S_v|.
    directions: also return the principal directions (unit (n, 3) vectors in 3-D).
    Returns a SurfaceDifferentials.
    """
    if len(derivatives) == 6:
        derivatives = derivatives[1:]
    if len(derivatives) != 5:
        raise InputError("expected (S, Su, Sv, Suu, Suv, Svv) or (Su, Sv, Suu, Suv, Svv), got %d arrays"
                         % len(derivatives))
    su = _check("Su", derivatives[0])
    n = su.shape[0]
    sv, suu, suv, svv = (_check(name, a, n) for name, a in zip(("Sv", "Suu", "Suv", "Svv"), derivatives[1:]))
    if orientation_sign not in (1, -1):
        raise InputError("orientation_sign must be +1 or -1, got %r" % (orientation_sign,))

    E, F, G = _dot(su, su), _dot(su, sv), _dot(sv, sv)
    c = _cross(su, sv)
    D = _dot(c, c)
    J = np.sqrt(D)
    ref = np.maximum(E, G) if scale is None else np.broadcast_to(np.asarray(scale, dtype=float), (n,))
    with np.errstate(invalid="ignore"):
        regular = (J > eps * ref) & np.isfinite(J) & np.isfinite(E) & np.isfinite(G)
        regular &= np.isfinite(suu).all(axis=1) & np.isfinite(suv).all(axis=1) & np.isfinite(svv).all(axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        inv_j = np.where(regular, float(orientation_sign) / np.where(regular, J, 1.0), np.nan)
        normal = c * inv_j[:, None]
        e, f, g = _dot(normal, suu), _dot(normal, suv), _dot(normal, svv)
        inv_d = np.where(regular, 1.0 / np.where(regular, D, 1.0), np.nan)
        H = (e * G - 2.0 * f * F + g * E) * (0.5 * inv_d)
        K = (e * g - f * f) * inv_d
        disc = np.sqrt(np.maximum(H * H - K, 0.0))
    k1, k2 = H + disc, H - disc
    dir1 = dir2 = None
    if directions:
        dir1, dir2 = _principal_directions(su, sv, normal, E, F, G, e, f, g, k1, k2)
    return SurfaceDifferentials(E, F, G, D, J, normal, e, f, g, H, K, k1, k2, regular, dir1, dir2)


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
