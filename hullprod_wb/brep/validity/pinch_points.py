"""The neighbourhood of a pinch point: an isolated zero p of N = S_u x S_v inside a knot
span where the Jacobian A = [N_u N_v] (3 x 2) has rank two (geometry.degenerate_points), integrated
through polar coordinates in the metric in which J is isotropic (paper section 4.3).

Near p, N = A (u - p) + O(|u - p|^2), so J = |A (u - p)| to first order. With A = U S V^T
(singular value decomposition) and the whitened coordinates x = S V^T (u - p), J = |x|:
round, whatever the ratio of the singular values. In the parameter plane J is small along
the direction of the smaller singular value, and |K| J, which grows like the inverse of
the distance, peaks sharply along that ray (the narrower the smaller the ratio); in whitened
polar coordinates (rho, theta) that peak is spread over the angle, and |K| J rho is smooth.

The box of half-widths (r_u, r_v) around p (the union of its four neighbourhood quadrants)
is cut into triangles, p and a piece of a side each; on triangle (p, c0, c1) the map from the
unit square is theta = theta0 + t (theta1 - theta0) (whitened angles of c0 - p, c1 - p),
u = p + s lam(t) d(t), d = M (cos theta, sin theta), M = V S^-1, lam(t) the distance along d
to the side, and du dv = |det M| s lam^2 |theta1 - theta0| ds dt.
"""
import numpy as np

from ..geometry.degenerate_points import jacobian_of_normal

#: Largest whitened angle of one triangle of a pinch point's box.
MAX_ANGLE = np.pi / 4


class PinchTriangleField:
    """Field on (s, t) in [0, 1]^2 of the triangle (p, c0, c1) through whitened polar
    coordinates (module docstring): J multiplied by the map's Jacobian."""

    def __init__(self, face_field, p, c0, c1, M):
        self.ff = face_field
        self.p = np.asarray(p, dtype=float)
        self.M = np.asarray(M, dtype=float)
        Minv = np.linalg.inv(self.M)
        a0, a1 = (Minv @ (np.asarray(c, dtype=float) - self.p) for c in (c0, c1))
        self.th0 = float(np.arctan2(a0[1], a0[0]))
        # signed: M may reverse the orientation
        self.dth = float((np.arctan2(a1[1], a1[0]) - self.th0 + np.pi) % (2.0 * np.pi) - np.pi)
        self.c0 = np.asarray(c0, dtype=float)
        self.edge = np.asarray(c1, dtype=float) - self.c0
        self.detM = abs(float(np.linalg.det(self.M)))

    def _lam_d(self, t):
        """lam(t) (n,) and d(t) (2, n) at t (n,)."""
        th = self.th0 + self.dth * np.asarray(t, dtype=float).ravel()
        d = self.M @ np.stack((np.cos(th), np.sin(th)))
        e, q = self.edge, self.c0 - self.p
        return (q[0] * e[1] - q[1] * e[0]) / (d[0] * e[1] - d[1] * e[0]), d

    def point_on_side(self, t):
        """The point of the side (c0, c1) at whitened angle th0 + t (th1 - th0), (2,)."""
        lam, d = self._lam_d(np.array([t], dtype=float))
        return self.p + lam[0] * d[:, 0]

    def __call__(self, s, t):
        s = np.asarray(s, dtype=float)
        shape = np.shape(t)
        lam, d = self._lam_d(t)
        lam = lam.reshape(shape)
        u = self.p[0] + s * lam * d[0].reshape(shape)
        v = self.p[1] + s * lam * d[1].reshape(shape)
        f = self.ff(u, v)
        jac = (self.detM * abs(self.dth)) * s * lam * lam
        return {"J": f["J"] * jac.ravel(), "K": f["K"], "H": f["H"], "regular": f["regular"]}


def whitening(evaluator, p):
    """M = V S^-1 of the singular value decomposition A = U S V^T of [N_u N_v] at p (2 x 2):
    the parameter offset u - p = M x of whitened coordinates x, in which |A (u - p)| = |x|."""
    A = jacobian_of_normal(evaluator, p)
    _, sv, vt = np.linalg.svd(A)
    return vt.T / sv[None, :]


def pinch_triangles(face_field, p, ru, rv):
    """The PinchTriangleFields of the box [pu - ru, pu + ru] x [pv - rv, pv + rv] around the
    pinch point p, counterclockwise: each side of the box cut into pieces of at most
    MAX_ANGLE of whitened angle seen from p (where the whitening shears the box into a
    long parallelogram, the distance to a long side varies less on each piece)."""
    pu, pv = p
    pt = np.array([pu, pv], dtype=float)
    corners = [(pu - ru, pv - rv), (pu + ru, pv - rv), (pu + ru, pv + rv), (pu - ru, pv + rv)]
    M = whitening(face_field.evaluator, p)
    out = []
    for k in range(4):
        c0, c1 = np.array(corners[k], dtype=float), np.array(corners[(k + 1) % 4], dtype=float)
        side = PinchTriangleField(face_field, pt, c0, c1, M)
        n = max(1, int(np.ceil(abs(side.dth) / MAX_ANGLE)))
        ends = [side.point_on_side(i / n) for i in range(n + 1)]
        out += [PinchTriangleField(face_field, pt, a, b, M) for a, b in zip(ends[:-1], ends[1:])]
    return out
