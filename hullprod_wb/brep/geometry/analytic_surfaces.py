"""Closed-form points and derivatives of OpenCascade's elementary surfaces.

Every elementary surface is written in its local frame (origin O, unit axes X, Y, Z of
the surface's gp_Ax3, which may be left-handed) as S(u, v) = O + a X + b Y + c Z, with
OpenCascade's parameterisations (ElSLib), cos/sin abbreviated c/s:

    plane     (a, b, c) = (u, v, 0)
    cylinder  (a, b, c) = (R cu, R su, v)
    cone      (a, b, c) = (rho cu, rho su, v cos A),      rho = R + v sin A  (A: semi-angle)
    sphere    (a, b, c) = (R cv cu, R cv su, R sv)
    torus     (a, b, c) = (rho cu, rho su, r sv),         rho = R + r cv

The partial derivatives (eq:brep_first_form, eq:brep_second_form need up to order 2)
are the exact derivatives of these expressions. The frame is read from the surface
itself (axis, location and OCC's own first/second derivatives at u = 0), so that
left-handed frames of mirrored geometry are reproduced.
"""
import numpy as np

from ...core.errors import InputError
from .nurbs import as_points


def _vec(p):
    return np.array([p.x, p.y, p.z], dtype=float)


def _unit(x, what):
    n = float(np.linalg.norm(x))
    if not np.isfinite(n) or n == 0.0:
        raise InputError("cannot determine the %s of an elementary surface" % what)
    return x / n


class AnalyticSurface:
    """Base class: a local frame and the coefficient functions (a, b, c) of S and derivatives.

    origin: (3,) float; frame: (3, 3) float, rows X, Y, Z. Subclasses implement
    ``_coefficients(u, v, order)`` returning a list of (n, 3) coefficient arrays
    (S, Su, Sv, Suu, Suv, Svv truncated to the order) in the local frame.
    """

    kind = None

    def __init__(self, origin, xdir, ydir, zdir):
        self.origin = np.asarray(origin, dtype=float).reshape(3)
        self.frame = np.array([xdir, ydir, zdir], dtype=float).reshape(3, 3)

    def evaluate(self, u, v, order=2):
        """S and partial derivatives up to total order ``order``, each (n, 3) float."""
        if order not in (0, 1, 2):
            raise InputError("derivative order must be 0, 1 or 2, got %r" % (order,))
        u, v = as_points(u, v)
        coeffs = self._coefficients(u, v, order)
        out = [c @ self.frame for c in coeffs]
        out[0] += self.origin
        return tuple(out)

    def derivatives(self, u, v):
        """(S, Su, Sv, Suu, Suv, Svv) at (u, v), each (n, 3) float."""
        return self.evaluate(u, v, 2)

    def points(self, u, v):
        """Surface points S(u, v), (n, 3) float."""
        return self.evaluate(u, v, 0)[0]

    @staticmethod
    def _stack(*cols):
        n = max(np.shape(c)[0] for c in cols if np.ndim(c))
        return np.column_stack([np.broadcast_to(c, (n,)) for c in cols])

    @classmethod
    def _revolved_frame(cls, surface, origin, rho0, v0):
        """Frame of a surface of revolution about Z from OCC derivatives at (0, v0).

        At u = 0: S_u = rho0 Y and S_uu = -rho0 X, with rho0 the (signed) distance factor.
        """
        z = _unit(_vec(surface.Axis), "axis")
        x_raw = -_vec(surface.getDN(0.0, v0, 2, 0)) / rho0
        y_raw = _vec(surface.getDN(0.0, v0, 1, 0)) / rho0
        return cls._orthonormal(origin, x_raw, y_raw, z)

    @staticmethod
    def _orthonormal(origin, x_raw, y_raw, z):
        x = _unit(x_raw - np.dot(x_raw, z) * z, "X direction")
        y0 = np.cross(z, x)
        sign = 1.0 if np.dot(y_raw, y0) >= 0.0 else -1.0  # -1: left-handed (indirect) frame
        return origin, x, sign * y0, z


class PlaneSurface(AnalyticSurface):
    """Plane S = O + u X + v Y."""

    kind = "plane"

    @classmethod
    def from_surface(cls, surface):
        z = _unit(_vec(surface.Axis), "axis")
        x_raw = _vec(surface.getDN(0.0, 0.0, 1, 0))
        y_raw = _vec(surface.getDN(0.0, 0.0, 0, 1))
        return cls(*cls._orthonormal(_vec(surface.Position), x_raw, y_raw, z))

    def _coefficients(self, u, v, order):
        zero, one = np.zeros_like(u), np.ones_like(u)
        out = [self._stack(u, v, zero)]
        if order >= 1:
            out += [self._stack(one, zero, zero), self._stack(zero, one, zero)]
        if order >= 2:
            z3 = np.zeros((u.shape[0], 3))
            out += [z3, z3.copy(), z3.copy()]
        return out


class CylinderSurface(AnalyticSurface):
    """Cylinder S = O + R (cos u X + sin u Y) + v Z."""

    kind = "cylinder"

    def __init__(self, origin, xdir, ydir, zdir, radius):
        super().__init__(origin, xdir, ydir, zdir)
        self.radius = float(radius)

    @classmethod
    def from_surface(cls, surface):
        r = float(surface.Radius)
        return cls(*cls._revolved_frame(surface, _vec(surface.Center), r, 0.0), r)

    def _coefficients(self, u, v, order):
        r = self.radius
        cu, su = np.cos(u), np.sin(u)
        zero = np.zeros_like(u)
        out = [self._stack(r * cu, r * su, v)]
        if order >= 1:
            out += [self._stack(-r * su, r * cu, zero), self._stack(zero, zero, np.ones_like(u))]
        if order >= 2:
            out += [self._stack(-r * cu, -r * su, zero), np.zeros((u.shape[0], 3)), np.zeros((u.shape[0], 3))]
        return out


class ConeSurface(AnalyticSurface):
    """Cone S = O + (R + v sin A)(cos u X + sin u Y) + v cos A Z (A: signed semi-angle)."""

    kind = "cone"

    def __init__(self, origin, xdir, ydir, zdir, radius, semi_angle):
        super().__init__(origin, xdir, ydir, zdir)
        self.radius = float(radius)
        self.semi_angle = float(semi_angle)

    @classmethod
    def from_surface(cls, surface):
        r, a = float(surface.Radius), float(surface.SemiAngle)
        v0 = 0.0 if r != 0.0 else 1.0  # a parallel of non-zero radius
        rho0 = r + v0 * np.sin(a)
        return cls(*cls._revolved_frame(surface, _vec(surface.Center), rho0, v0), r, a)

    def _coefficients(self, u, v, order):
        sa, ca = np.sin(self.semi_angle), np.cos(self.semi_angle)
        cu, su = np.cos(u), np.sin(u)
        rho = self.radius + v * sa
        zero = np.zeros_like(u)
        out = [self._stack(rho * cu, rho * su, v * ca)]
        if order >= 1:
            out += [self._stack(-rho * su, rho * cu, zero), self._stack(sa * cu, sa * su, np.full_like(u, ca))]
        if order >= 2:
            out += [self._stack(-rho * cu, -rho * su, zero), self._stack(-sa * su, sa * cu, zero),
                    np.zeros((u.shape[0], 3))]
        return out


class SphereSurface(AnalyticSurface):
    """Sphere S = O + R cos v (cos u X + sin u Y) + R sin v Z."""

    kind = "sphere"

    def __init__(self, origin, xdir, ydir, zdir, radius):
        super().__init__(origin, xdir, ydir, zdir)
        self.radius = float(radius)

    @classmethod
    def from_surface(cls, surface):
        r = float(surface.Radius)
        return cls(*cls._revolved_frame(surface, _vec(surface.Center), r, 0.0), r)

    def _coefficients(self, u, v, order):
        r = self.radius
        cu, su, cv, sv = np.cos(u), np.sin(u), np.cos(v), np.sin(v)
        zero = np.zeros_like(u)
        out = [self._stack(r * cv * cu, r * cv * su, r * sv)]
        if order >= 1:
            out += [self._stack(-r * cv * su, r * cv * cu, zero), self._stack(-r * sv * cu, -r * sv * su, r * cv)]
        if order >= 2:
            out += [self._stack(-r * cv * cu, -r * cv * su, zero), self._stack(r * sv * su, -r * sv * cu, zero),
                    self._stack(-r * cv * cu, -r * cv * su, -r * sv)]
        return out


class TorusSurface(AnalyticSurface):
    """Torus S = O + (R + r cos v)(cos u X + sin u Y) + r sin v Z."""

    kind = "torus"

    def __init__(self, origin, xdir, ydir, zdir, major_radius, minor_radius):
        super().__init__(origin, xdir, ydir, zdir)
        self.major_radius = float(major_radius)
        self.minor_radius = float(minor_radius)

    @classmethod
    def from_surface(cls, surface):
        big, small = float(surface.MajorRadius), float(surface.MinorRadius)
        return cls(*cls._revolved_frame(surface, _vec(surface.Center), big + small, 0.0), big, small)

    def _coefficients(self, u, v, order):
        big, r = self.major_radius, self.minor_radius
        cu, su, cv, sv = np.cos(u), np.sin(u), np.cos(v), np.sin(v)
        rho = big + r * cv
        zero = np.zeros_like(u)
        out = [self._stack(rho * cu, rho * su, r * sv)]
        if order >= 1:
            out += [self._stack(-rho * su, rho * cu, zero), self._stack(-r * sv * cu, -r * sv * su, r * cv)]
        if order >= 2:
            out += [self._stack(-rho * cu, -rho * su, zero), self._stack(r * sv * su, -r * sv * cu, zero),
                    self._stack(-r * cv * cu, -r * cv * su, -r * sv)]
        return out


#: FreeCAD class name -> closed-form evaluator class.
ANALYTIC_TYPES = {
    "Plane": PlaneSurface,
    "Cylinder": CylinderSurface,
    "Cone": ConeSurface,
    "Sphere": SphereSurface,
    "Toroid": TorusSurface,
}


def analytic_from_surface(surface):
    """Closed-form evaluator for a Part.Plane/Cylinder/Cone/Sphere/Toroid, else None."""
    cls = ANALYTIC_TYPES.get(type(surface).__name__)
    return None if cls is None else cls.from_surface(surface)
