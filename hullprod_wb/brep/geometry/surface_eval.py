"""Batched evaluation of a BRep face's surface S(u, v) and its derivatives (eq:brep_surface).

:class:`SurfaceEvaluator` picks, once per face, the fastest exact evaluator for the
face's geometric surface:

* ``bspline`` / ``bezier``: vectorised NURBS evaluation (:mod:`.nurbs`);
* ``plane``, ``cylinder``, ``cone``, ``sphere``, ``torus``: closed forms
  (:mod:`.analytic_surfaces`);
* anything else (surfaces of revolution/extrusion, offset surfaces, ...): OpenCascade's
  own ``value``/``getDN`` per point, kind ``occ:<TypeName>`` (exact but slow).

Rectangular-trimmed wrappers are unwrapped (they share their basis surface's
parameterisation). The face's orientation enters only through ``orientation_sign``
(+1 Forward, -1 Reversed), used for the normal and H (eq:brep_normal, eq:brephk).
"""
import numpy as np

from ...core.errors import InputError
from . import differential
from .analytic_surfaces import analytic_from_surface
from ..cubature.cells import grid_points
from .nurbs import NurbsSurfaceData, as_points, knot_breaks
from ..reading.occ_records import orientation_sign_of, unwrap_surface


def face_surface(face):
    """The geometric surface used by a Part.Face and its parameter range.

    Returns (surface, (umin, umax, vmin, vmax)). ``face.Surface`` already carries the
    face's placement; the range is ``face.ParameterRange`` (the bounds of the trimmed
    parameter domain).
    """
    if getattr(face, "ShapeType", None) != "Face":
        raise InputError("expected a Part.Face, got %s" % (getattr(face, "ShapeType", None) or type(face).__name__))
    try:
        surface = face.Surface
        prange = tuple(float(x) for x in face.ParameterRange)
    except Exception as exc:  # OCC raises its own exception types
        raise InputError("the face's surface cannot be read by FreeCAD: %s" % exc) from exc
    return surface, prange


class _OccBackend:
    """Per-point OpenCascade evaluation (value and getDN) for surfaces without a closed form."""

    _ORDERS = ((1, 0), (0, 1), (2, 0), (1, 1), (0, 2))

    def __init__(self, surface):
        self.surface = surface

    def evaluate(self, u, v, order=2):
        u, v = as_points(u, v)
        n = u.shape[0]
        orders = self._ORDERS[:(0, 2, 5)[order]]
        out = np.empty((1 + len(orders), n, 3))
        value, get_dn = self.surface.value, self.surface.getDN
        for i in range(n):  # no batched OCC entry point exists in FreeCAD's Python API
            a, b = float(u[i]), float(v[i])
            p = value(a, b)
            out[0, i] = (p.x, p.y, p.z)
            for k, (nu, nv) in enumerate(orders, 1):
                d = get_dn(a, b, nu, nv)
                out[k, i] = (d.x, d.y, d.z)
        return tuple(out)


def _curve_breaks(curve, lo, hi, min_continuity):
    """Knot breaks of a B-spline basis curve inside (lo, hi); none for other curves."""
    while type(curve).__name__ == "TrimmedCurve" and hasattr(curve, "BasisCurve"):
        curve = curve.BasisCurve
    if type(curve).__name__ != "BSplineCurve":
        return np.empty(0)
    period = float(curve.LastParameter - curve.FirstParameter) if curve.isPeriodic() else None
    return knot_breaks(curve.getKnots(), curve.getMultiplicities(), curve.Degree, lo, hi,
                       period=period, min_continuity=min_continuity)


def _surface_breaks(surface, urange, vrange, min_continuity):
    """(u_breaks, v_breaks) of any surface (recursive through basis curves/surfaces)."""
    surface = unwrap_surface(surface)
    name = type(surface).__name__
    if name == "BSplineSurface":
        data = NurbsSurfaceData.from_surface(surface)
        return (data.breaks("u", *urange, min_continuity=min_continuity),
                data.breaks("v", *vrange, min_continuity=min_continuity))
    if name == "SurfaceOfExtrusion":  # u: curve parameter, v: straight line
        return _curve_breaks(surface.BasisCurve, *urange, min_continuity), np.empty(0)
    if name == "SurfaceOfRevolution":  # u: angle, v: curve parameter
        return np.empty(0), _curve_breaks(surface.BasisCurve, *vrange, min_continuity)
    if name == "OffsetSurface":  # the offset loses one order of smoothness (uses the normal)
        inner = None if min_continuity is None else int(min_continuity) + 1
        return _surface_breaks(surface.BasisSurface, urange, vrange, inner)
    return np.empty(0), np.empty(0)


class SurfaceEvaluator:
    """Exact, batched S, S_u, S_v, S_uu, S_uv, S_vv of one face's (or surface's) geometry.

    Attributes
    ----------
    kind : str               'bspline', 'bezier', 'plane', 'cylinder', 'cone', 'sphere',
                             'torus' or 'occ:<FreeCAD type name>'
    surface : Part surface   the unwrapped geometric surface that is evaluated
    orientation_sign : int   +1 Forward, -1 Reversed
    parameter_range : (umin, umax, vmin, vmax) floats (face.ParameterRange, or the bounds)
    nurbs : NurbsSurfaceData or None;  analytic : AnalyticSurface or None
    """

    def __init__(self, surface, orientation_sign=1, parameter_range=None):
        if orientation_sign not in (1, -1):
            raise InputError("orientation_sign must be +1 or -1, got %r" % (orientation_sign,))
        self.surface = unwrap_surface(surface)
        self.orientation_sign = int(orientation_sign)
        if parameter_range is None:
            parameter_range = surface.bounds()
        self.parameter_range = tuple(float(x) for x in parameter_range)
        if len(self.parameter_range) != 4:
            raise InputError("parameter_range must be (umin, umax, vmin, vmax)")
        self.nurbs = None
        self.analytic = None
        name = type(self.surface).__name__
        if name in ("BSplineSurface", "BezierSurface"):
            self.nurbs = NurbsSurfaceData.from_surface(self.surface)
            self.kind = "bspline" if name == "BSplineSurface" else "bezier"
            self._backend = self.nurbs
        else:
            self.analytic = analytic_from_surface(self.surface)
            if self.analytic is not None:
                self.kind = self.analytic.kind
                self._backend = self.analytic
            else:
                self.kind = "occ:" + name
                self._backend = _OccBackend(self.surface)

    @classmethod
    def from_record(cls, rec):
        """Evaluator of a B-spline or Bezier face from its occ_records.FaceData (no Part
        surface: surface is None), the same as for_face of that face."""
        self = cls.__new__(cls)
        self.surface = None
        self.orientation_sign = int(rec.orientation_sign)
        self.parameter_range = tuple(float(x) for x in rec.parameter_range)
        self.nurbs = NurbsSurfaceData.from_record(rec.nurbs)
        self.analytic = None
        self.kind = rec.kind
        self._backend = self.nurbs
        return self

    @classmethod
    def for_face(cls, face):
        """Evaluator of a Part.Face: its surface, orientation sign and ParameterRange."""
        surface, prange = face_surface(face)
        return cls(surface, orientation_sign_of(face), prange)

    @classmethod
    def for_surface(cls, surface, orientation_sign=1, parameter_range=None):
        """Evaluator of a bare Part surface (range: surface.bounds() unless given)."""
        return cls(surface, orientation_sign, parameter_range)

    @property
    def vectorised(self):
        """False for the per-point OpenCascade fallback."""
        return not isinstance(self._backend, _OccBackend)

    def points(self, u, v):
        """S(u, v), (n, 3) float; u, v array-like broadcast to n points."""
        return self._backend.evaluate(u, v, 0)[0]

    def first_derivatives(self, u, v):
        """(S, Su, Sv), each (n, 3) float."""
        return self._backend.evaluate(u, v, 1)

    def derivatives(self, u, v):
        """(S, Su, Sv, Suu, Suv, Svv), each (n, 3) float."""
        return self._backend.evaluate(u, v, 2)

    def rounding(self, uv_of):
        """For differential.curvature_fields: (r_of, c) with r_of(i) the bounds (len(i), 5)
        of the rounding of the derivatives at the points uv_of(i) = (u_i, v_i) of indices i
        (NurbsSurfaceData.rounding) and c the surface's curvature scale; None for other
        surfaces, whose derivatives come from closed forms or OpenCascade."""
        if self.nurbs is None:
            return None
        return (lambda i: self.nurbs.rounding(*uv_of(i))), self.nurbs.curvature_scale

    def grid_derivatives(self, u, v, order=2):
        """derivatives (order 2) or first_derivatives (order 1) on the tensor grids u (n, a) x
        v (n, b): the points (u[c, i], v[c, j]) flat in [c, i, j] order (n a b, 3) each.
        B-spline and Bezier surfaces share each grid's basis functions and poles
        (NurbsSurfaceData.evaluate_grid); other surfaces are evaluated point by point."""
        if self.nurbs is not None:
            return self.nurbs.evaluate_grid(u, v, order)
        return self._backend.evaluate(*grid_points(u, v), order)

    def differentials(self, u, v, eps=differential.DEFAULT_DEGENERACY_EPS, scale=None, directions=False):
        """Fundamental forms, oriented normal, H, K, k1 >= k2 at (u, v) (eq:brephk), K zero
        within its rounding (differential.curvature_fields).

        Returns differential.SurfaceDifferentials (arrays of length n); see
        differential.surface_differentials for eps, scale and directions.
        """
        u, v = as_points(u, v)
        return differential.surface_differentials(self.derivatives(u, v), self.orientation_sign, eps=eps,
                                                  scale=scale, directions=directions,
                                                  rounding=self.rounding(lambda i: (u[i], v[i])))

    def continuity_breaks(self, min_continuity=None, urange=None, vrange=None):
        """Parameter lines inside the range where the integrand may lose smoothness.

        Returns (u_breaks, v_breaks), sorted 1-D float arrays strictly inside urange and
        vrange (default: parameter_range). min_continuity None (default): every distinct
        knot line of a spline (the surface is a single polynomial/rational patch between
        them, so Gauss rules converge exponentially inside each cell). An integer c: only
        lines where the surface is less smooth than C^c (knot multiplicity > degree - c);
        c = 2 gives the lines where second derivatives, hence H and K, jump. Periodic
        knots repeat by the period. Elementary surfaces have no breaks; surfaces of
        extrusion/revolution use their basis curve's knots, offset surfaces their basis
        surface's (one order stricter); other fallback surfaces report none.
        """
        u0, u1, v0, v1 = self.parameter_range
        urange = (u0, u1) if urange is None else (float(urange[0]), float(urange[1]))
        vrange = (v0, v1) if vrange is None else (float(vrange[0]), float(vrange[1]))
        if self.nurbs is not None:
            return (self.nurbs.breaks("u", *urange, min_continuity=min_continuity),
                    self.nurbs.breaks("v", *vrange, min_continuity=min_continuity))
        if self.analytic is not None:
            return np.empty(0), np.empty(0)
        return _surface_breaks(self.surface, urange, vrange, min_continuity)

    def __repr__(self):
        return "SurfaceEvaluator(kind=%r, orientation_sign=%d, parameter_range=%r)" % (
            self.kind, self.orientation_sign, self.parameter_range)
