"""The integrand field of one BRep face: (u, v) -> J, K, H, regular (paper eq:brephk,
eq:brep_jacobian), evaluated in batches from the exact surface derivatives."""
import numpy as np

from .differential import curvature_fields, jacobian, principal_curvatures
from .surface_eval import SurfaceEvaluator


class FaceField:
    """Callable field of a Part.Face for the quadrature, counting evaluated points.

    field(u, v) with u, v (n,) float returns dict(J, K, H, k1, k2, regular, points).
    face may be None for a field built from a face's plain records (recorded_shape): then
    evaluator and surface_type (FreeCAD's name of the face's surface type) are given.
    """

    def __init__(self, face, evaluator=None, surface_type=None):
        self.face = face
        self.evaluator = evaluator or SurfaceEvaluator.for_face(face)
        self.surface_type = surface_type or type(face.Surface).__name__
        self.kind = self.evaluator.kind
        self.sign = self.evaluator.orientation_sign
        self.points_evaluated = 0

    def __call__(self, u, v):
        u = np.asarray(u, dtype=float).ravel()
        v = np.asarray(v, dtype=float).ravel()
        self.points_evaluated += u.size
        return self._fields(self.evaluator.derivatives(u, v), self.evaluator.rounding(lambda i: (u[i], v[i])))

    def grid(self, u, v):
        """The field on the tensor grids u (n, a) x v (n, b) (SurfaceEvaluator.grid_derivatives),
        flat in [c, i, j] order: the same dict as field(U.ravel(), V.ravel()) of the broadcast
        grids, without k1 and k2."""
        der = self.evaluator.grid_derivatives(u, v)
        self.points_evaluated += der[0].shape[0]
        u, v = np.asarray(u, dtype=float), np.asarray(v, dtype=float)
        a, b = u.shape[1], v.shape[1]

        def uv_of(i):  # point i = (c a + k) b + l of the grids: (u[c, k], v[c, l])
            return u.ravel()[i // b], v.ravel()[(i // (a * b)) * b + i % b]
        return self._fields(der, self.evaluator.rounding(uv_of), principal=False)

    def _fields(self, der, rounding, principal=True):
        """dict(J, K, H, regular, points) and, with principal, k1 >= k2 (the cubature's
        grids go without); K zero within its rounding where the derivatives' rounding
        bounds are known (differential.curvature_fields)."""
        d = curvature_fields(der, orientation_sign=self.sign, rounding=rounding)
        out = {"J": d.J, "K": d.K, "H": d.H, "regular": d.regular, "points": der[0]}
        if principal:
            out["k1"], out["k2"] = principal_curvatures(d.H, d.K)
        return out

    def area_element(self, u, v):
        """J = |S_u x S_v| alone (eq:brep_jacobian), from first derivatives only, as a field
        for area integrals: dict(J, K, H, regular) with K = H = 0 and regular where J is
        finite (the class and curvature quantities of such a field are meaningless)."""
        u = np.asarray(u, dtype=float).ravel()
        v = np.asarray(v, dtype=float).ravel()
        return self._area_fields(self.evaluator.first_derivatives(u, v))

    def area_element_grid(self, u, v):
        """area_element on the tensor grids u (n, a) x v (n, b), flat in [c, i, j] order."""
        return self._area_fields(self.evaluator.grid_derivatives(u, v, 1))

    @staticmethod
    def _area_fields(der):
        J = jacobian(der[1], der[2])
        zero = np.zeros(J.size)
        return {"J": J, "K": zero, "H": zero, "regular": np.isfinite(J)}
