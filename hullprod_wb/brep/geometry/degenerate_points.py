"""Isolated zeros of the normal vector N = S_u x S_v inside the knot spans of a surface:
degenerate points of the parameterisation (J = |N| = 0, paper eq:brep_jacobian) that are not
nodes of the knot grid, where |K| may grow without bound (paper section 4.3).

From every sample of the spans where each component of N may vanish, Gauss-Newton on the three equations
N(u, v) = 0 in two unknowns, with the Jacobian columns N_u = S_uu x S_v + S_u x S_uv and
N_v = S_uv x S_v + S_u x S_vv, all spans in one array pass. A zero of full rank converges
quadratically; an iterate that stops approaching J = 0 has no zero near its sample, and a
zero where [N_u N_v] has rank below two lies on a line of zeros (a collapsed side)."""
import numpy as np

#: Samples per span and direction from which the iteration starts (the smallest J / max(E, G)).
START_SAMPLES = 4
#: Gauss-Newton steps at most.
NEWTON_STEPS = 40
#: A step must shrink J / max(E, G) by at least this factor for the iterate to stay (after the
#: first two steps, which may leave a poor start).
SHRINK = 0.7
#: The zero is isolated when the smaller singular value of [N_u N_v] exceeds this fraction of
#: the larger.
RANK_RTOL = 1e-3
#: Newton steps taken after J / max(E, G) fell below rtol (quadratic convergence: the zero
#: to the rounding of N).
POLISH_STEPS = 2
#: Zeros closer than this fraction of the parameter ranges are one.
SAME = 1e-7


def _normals(derivatives):
    """N = S_u x S_v, its partial derivatives and max(E, G) of derivatives (S, S_u, S_v, S_uu,
    S_uv, S_vv) (n, 3) each."""
    _, su, sv, suu, suv, svv = derivatives
    n = np.cross(su, sv)
    nu = np.cross(suu, sv) + np.cross(su, suv)
    nv = np.cross(suv, sv) + np.cross(su, svv)
    scale = np.maximum((su * su).sum(1), (sv * sv).sum(1))
    return n, nu, nv, scale


def jacobian_of_normal(evaluator, p):
    """[N_u N_v] at the parameter point p = (u, v), (3, 2)."""
    _, nu, nv, _ = _normals(evaluator.derivatives(np.array([float(p[0])]), np.array([float(p[1])])))
    return np.stack((nu[0], nv[0]), 1)


def _may_vanish(n):
    """(m,) bool: spans whose samples n (m, s, 3) of N leave each component's zero within its
    sampled range of the samples (N is a polynomial on a span: a component that stays one
    sign by more than its variation over the samples does not vanish there)."""
    lo, hi = n.min(1), n.max(1)
    spread = hi - lo
    return np.all((lo <= spread) & (hi >= -spread), 1)


def _full_rank(nu, nv):
    """(n,) bool: the Jacobian [N_u N_v] (n, 3) each has rank two (its smaller singular value
    above RANK_RTOL of the larger): an isolated zero, not a line of zeros such as a collapsed
    side, along which N's derivative vanishes."""
    A = np.stack((nu, nv), 2)
    sv = np.linalg.svd(A, compute_uv=False)
    return sv[:, 1] > RANK_RTOL * sv[:, 0]


def isolated_zeros(evaluator, gu, gv, rtol):
    """Points (u, v) inside or on the knot spans of the grid gu x gv (sorted break values, the
    ends included) where J / max(E, G) <= rtol at the end of the iteration: a list of (u, v)
    floats, each at most once. evaluator: SurfaceEvaluator (derivatives(u, v))."""
    gu, gv = np.asarray(gu, dtype=float), np.asarray(gv, dtype=float)
    if gu.size < 2 or gv.size < 2:
        return []
    ua, ub = np.meshgrid(gu[:-1], gv[:-1], indexing="ij")
    uz, vz = np.meshgrid(gu[1:], gv[1:], indexing="ij")
    a, b, c, d = ua.ravel(), uz.ravel(), ub.ravel(), vz.ravel()
    g = (np.arange(START_SAMPLES) + 0.5) / START_SAMPLES
    su_, sv_ = np.meshgrid(g, g, indexing="ij")
    U = (a[:, None] + (b - a)[:, None] * su_.ravel()[None]).ravel()
    V = (c[:, None] + (d - c)[:, None] * sv_.ravel()[None]).ravel()
    _, su, sv = evaluator.first_derivatives(U, V)
    n = np.cross(su, sv)
    rel = np.linalg.norm(n, axis=1) / np.maximum((su * su).sum(1), (sv * sv).sum(1))
    rel = np.nan_to_num(rel, nan=np.inf).reshape(a.size, -1)
    span, k = np.nonzero(np.isfinite(rel) & _may_vanish(n.reshape(a.size, -1, 3))[:, None])
    u, v = U.reshape(a.size, -1)[span, k], V.reshape(a.size, -1)[span, k]
    prev = rel[span, k]
    a, b, c, d = a[span], b[span], c[span], d[span]
    live = np.ones(u.size, bool)
    found = np.zeros(u.size, bool)
    polish = np.zeros(u.size, int)  # steps taken since J / max(E, G) fell below rtol
    for step in range(NEWTON_STEPS):
        idx = np.nonzero(live)[0]
        if not idx.size:
            break
        n, nu, nv, scale = _normals(evaluator.derivatives(u[idx], v[idx]))
        now = np.linalg.norm(n, axis=1) / scale
        zero = (now <= rtol) & _full_rank(nu, nv)
        found[idx] = zero
        polish[idx[zero]] += 1
        stuck = ~zero & (~np.isfinite(now) | ((now > SHRINK * prev[idx]) & (step >= 2)))
        done = zero & (polish[idx] > POLISH_STEPS)
        live[idx[done | stuck]] = False
        prev[idx] = now
        go = ~(done | stuck)
        idx = idx[go]
        if not idx.size:
            break
        A = np.stack((nu[go], nv[go]), 2)  # (k, 3, 2)
        AtA = np.einsum("kia,kib->kab", A, A)
        Atn = np.einsum("kia,ki->ka", A, n[go])
        det = AtA[:, 0, 0] * AtA[:, 1, 1] - AtA[:, 0, 1] ** 2
        ok = det > 0.0
        with np.errstate(divide="ignore", invalid="ignore"):
            du = -(AtA[:, 1, 1] * Atn[:, 0] - AtA[:, 0, 1] * Atn[:, 1]) / det
            dv = -(AtA[:, 0, 0] * Atn[:, 1] - AtA[:, 0, 1] * Atn[:, 0]) / det
        live[idx[~ok]] = False
        idx, du, dv = idx[ok], du[ok], dv[ok]
        u[idx] = np.clip(u[idx] + du, a[idx], b[idx])
        v[idx] = np.clip(v[idx] + dv, c[idx], d[idx])
    out = []
    tol_u, tol_v = SAME * (gu[-1] - gu[0]), SAME * (gv[-1] - gv[0])
    for x, y in zip(u[found], v[found]):
        if not any(abs(x - p) <= tol_u and abs(y - q) <= tol_v for p, q in out):
            out.append((float(x), float(y)))
    return out
