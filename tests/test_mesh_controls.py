"""Analytical controls of the mesh backend (paper section 5.1): plane, sphere, cylinder,
saddle, torus, half-Wigley, each with consistent, alternating and seeded-random diagonals;
invariances of the curvature reconstruction; fields against global values."""
import numpy as np
import pytest
from scipy import integrate

from hullprod_wb.core.constants import CLASS_METRICS, METRICS
from hullprod_wb.core.validity import Status
from hullprod_wb.examples.analytic_meshes import (PATTERNS, cylinder_mesh, grid_faces, half_wigley_mesh,
                                                  icosphere_mesh, plane_mesh, saddle_mesh, torus_mesh)
from hullprod_wb.examples.builtin import WIGLEY_REFERENCE
from hullprod_wb.mesh.backend import assess_mesh
from hullprod_wb.mesh.curvature import barycentric_vertex_areas, vertex_curvature

TORUS_ID = 128.0 / (3.0 * np.pi)          # R = 3, r = 1, L_ref = 8 (paper section 5.1)
TORUS_ID_SIGNED = 64.0 / (3.0 * np.pi)
TORUS_A_ELLIPTIC = 0.606102               # paper Table tab:brepanalytic (threshold-based)
WIGLEY_ID = WIGLEY_REFERENCE["I_D"]

#: Rounding-level tolerance for quantities the method reproduces exactly (sums of ~10
#: float64 products per vertex, values of order 1).
EXACT = 1e-10


def values(result):
    return {m: result.validity[m].value for m in METRICS}


def classes(result):
    return np.array([result.validity[m].value for m in CLASS_METRICS])


@pytest.mark.parametrize("pattern", PATTERNS)
def test_plane_is_flat(pattern):
    r = assess_mesh(plane_mesh(12, pattern=pattern), lref=2.0)
    v = values(r)
    # A plane has exactly parallel normals, so K and H vanish to rounding.
    assert v["I_D"] == pytest.approx(0.0, abs=EXACT)
    assert v["I_D_plus"] == pytest.approx(0.0, abs=EXACT) and v["I_D_minus"] == pytest.approx(0.0, abs=EXACT)
    assert np.allclose(classes(r), [1, 0, 0, 0], atol=EXACT)
    # the plane's boundary ring carries more than 5 % of its area at 12 x 12 quads
    assert r.validity["a_flat"].status == Status.MESH_SENSITIVE
    assert r.validity["a_flat"].evidence["excluded_area_fraction"] > 0.05


@pytest.mark.parametrize("pattern", PATTERNS)
@pytest.mark.parametrize("frequency", [4, 12])
def test_icosphere_unit_curvature(pattern, frequency):
    V, F = icosphere_mesh(frequency, pattern)
    assert np.allclose(np.linalg.norm(V, axis=1), 1.0, atol=1e-15)
    c = vertex_curvature(V, F)
    # Max's normals are exact for vertices on a sphere, so the normal differences are the
    # edge vectors and the exact least-squares fit is the identity on every face, at any
    # resolution and for any triangle shape: only rounding remains.
    assert np.max(np.abs(c.H + 1.0)) < EXACT  # outward normals: H = -1/R (eq:brephk sign)
    assert np.max(np.abs(c.K - 1.0)) < EXACT
    assert np.allclose(c.normals, V, atol=EXACT)
    assert not c.boundary.any()
    r = assess_mesh((V, F), lref=2.0)
    v = values(r)
    assert v["I_D"] == pytest.approx(4.0, rel=EXACT)
    assert v["I_D_plus"] == pytest.approx(4.0, rel=EXACT) and v["I_D_minus"] == pytest.approx(0.0, abs=EXACT)
    assert np.allclose(classes(r), [0, 0, 1, 0], atol=EXACT)
    # frequency 4 is coarse (adjacent normals differ by up to ~30 degrees): the advisory
    # cannot know that a sphere is reconstructed exactly and may call it sensitive
    expected = {Status.VALID} if frequency >= 12 else {Status.VALID, Status.MESH_SENSITIVE}
    assert r.validity["I_D"].status in expected


def test_sphere_of_scattered_points_is_exact():
    """Irregular triangles (convex hull of random points on a sphere): the per-face fit is
    solved exactly for any edge geometry, so H = -1/R (outward normals) and K = 1/R^2 still hold
    to rounding."""
    from scipy.spatial import ConvexHull
    rng = np.random.default_rng(3)
    P = rng.normal(size=(400, 3))
    P /= np.linalg.norm(P, axis=1)[:, None]
    P *= 2.5
    F = ConvexHull(P).simplices
    nrm = np.cross(P[F[:, 1]] - P[F[:, 0]], P[F[:, 2]] - P[F[:, 0]])
    inward = np.einsum("ij,ij->i", nrm, P[F].mean(axis=1)) < 0
    F[inward] = F[inward][:, ::-1]
    c = vertex_curvature(P, F)
    assert np.max(np.abs(c.H + 0.4)) < EXACT
    assert np.max(np.abs(c.K - 0.16)) < EXACT


@pytest.mark.parametrize("pattern", PATTERNS)
def test_open_cylinder_single_curvature(pattern):
    n_z = 32
    V, F = cylinder_mesh(48, n_z, radius=1.0, height=2.0, pattern=pattern)
    c = vertex_curvature(V, F)
    inner = ~c.boundary
    # Each quad of a cylinder grid is planar and symmetric, so the Max normals are radial
    # and the fitted tensors are rank one along the axis: K = 0, H = -1/(2r) (outward normals)
    # to rounding.
    assert np.max(np.abs(c.K[inner])) < EXACT
    assert np.max(np.abs(c.H[inner] + 0.5)) < EXACT
    assert c.boundary.sum() == 2 * 48
    r = assess_mesh((V, F), lref=2.0)
    v = values(r)
    assert v["I_D"] == pytest.approx(0.0, abs=EXACT)
    assert np.allclose(classes(r), [0, 1, 0, 0], atol=EXACT)
    ev = r.validity["I_D"].evidence
    # Each end ring carries half of one strip of quads: excluded = 1/n_z of the area.
    assert ev["excluded_area_fraction"] == pytest.approx(1.0 / n_z, rel=1e-12)
    assert ev["excluded"]["boundary_vertices"] == 2 * 48
    assert ev["excluded"]["boundary_vertex_area"] == pytest.approx(r.integrals.represented_area / n_z, rel=1e-12)
    assert r.integrals.valid_area == pytest.approx(r.integrals.represented_area * (1 - 1.0 / n_z), rel=1e-12)
    assert r.validity["I_D"].status == Status.VALID


def saddle_reference(lref=2.0):
    """L_ref^2 int |K| dA / A for z = (x^2 - y^2)/4 on [-1, 1]^2 by adaptive quadrature:
    |K| = (1/4) / (1 + rho^2/4)^2, dA = sqrt(1 + rho^2/4) dx dy."""
    J = lambda y, x: np.sqrt(1.0 + (x * x + y * y) / 4.0)  # noqa: E731
    KJ = lambda y, x: 0.25 / (1.0 + (x * x + y * y) / 4.0) ** 1.5  # noqa: E731
    a = integrate.dblquad(KJ, -1, 1, -1, 1, epsabs=1e-13, epsrel=1e-12)[0]
    A = integrate.dblquad(J, -1, 1, -1, 1, epsabs=1e-13, epsrel=1e-12)[0]
    return lref ** 2 * a / A


@pytest.mark.parametrize("pattern", PATTERNS)
def test_saddle_negative_curvature(pattern):
    ref = saddle_reference()
    assert ref == pytest.approx(0.746436, abs=1e-6)  # paper Table tab:brepanalytic, L_ref = 2
    errors = []
    for n in (16, 32, 64):
        r = assess_mesh(saddle_mesh(n, pattern), lref=2.0, with_fields=False)
        v = values(r)
        assert v["I_D"] == pytest.approx(v["I_D_plus"] + v["I_D_minus"], rel=1e-14)
        assert v["I_D_plus"] == 0.0
        # K < -0.11 everywhere while tau_K = 2.5e-5: every valid vertex is saddle
        assert v["a_saddle"] == 1.0
        errors.append(abs(v["I_D"] / ref - 1.0))
    # The boundary ring is excluded, so the domain error is first order in h.
    assert errors[0] > errors[1] > errors[2]
    assert errors[2] < 0.01


@pytest.mark.parametrize("pattern", PATTERNS)
def test_torus_converges(pattern):
    err, err_p, err_m, err_e = [], [], [], []
    for n in (8, 16, 32):
        r = assess_mesh(torus_mesh(n, pattern=pattern), lref=8.0, with_fields=False)
        v = values(r)
        assert r.integrals.valid_area == r.integrals.represented_area  # closed: nothing excluded
        assert v["I_D"] == pytest.approx(v["I_D_plus"] + v["I_D_minus"], rel=1e-14)
        err.append(abs(v["I_D"] / TORUS_ID - 1))
        err_p.append(abs(v["I_D_plus"] / TORUS_ID_SIGNED - 1))
        err_m.append(abs(v["I_D_minus"] / TORUS_ID_SIGNED - 1))
        err_e.append(abs(v["a_elliptic"] - TORUS_A_ELLIPTIC))
    # second order in h for the intensity: each halving of h divides the error by about 4
    for e in (err, err_p, err_m):
        assert e[1] < 0.35 * e[0] and e[2] < 0.35 * e[1]
    assert err[2] < 0.011 and err_p[2] < 0.008 and err_m[2] < 0.015
    # the class fractions count whole vertex areas, so they converge at first order
    assert err_e[0] > err_e[1] > err_e[2]
    assert err_e[2] < 0.04


def test_torus_principal_directions():
    """On the torus the principal directions are the parameter directions. With outward
    normals (eq:brephk sign): k2 = -1/r along the tube (v) and k1 = -cos v / (R + r cos v)
    >= -1/4 around the axis (u)."""
    V, F = torus_mesh(32)
    c = vertex_curvature(V, F)
    u = np.arctan2(V[:, 1], V[:, 0])
    around = np.stack([-np.sin(u), np.cos(u), np.zeros_like(u)], axis=1)
    rho = np.hypot(V[:, 0], V[:, 1])
    cos_v = (rho - 3.0) / 1.0
    # direction and curvature errors are O(h^2) like the tensor itself: about 1e-2 at n = 32
    assert np.all(np.abs(np.einsum("ij,ij->i", c.dir1, around)) > np.cos(0.02))
    assert np.all(np.abs(np.einsum("ij,ij->i", c.dir2, np.cross(c.normals, around))) > np.cos(0.02))
    assert np.allclose(c.k2, -1.0, atol=0.01)
    assert np.allclose(c.k1, -cos_v / rho, atol=0.01)


@pytest.mark.parametrize("pattern", PATTERNS)
def test_half_wigley_converges(pattern):
    errors = []
    for nx, nz in ((32, 8), (64, 16), (128, 32)):
        r = assess_mesh(half_wigley_mesh(nx, nz, pattern), lref=1.0, with_fields=False)
        v = values(r)
        assert v["I_D"] == pytest.approx(v["I_D_plus"] + v["I_D_minus"], rel=1e-14)
        assert r.integrals.valid_area < r.integrals.represented_area
        errors.append(abs(v["I_D"] / WIGLEY_ID - 1))
    # the excluded boundary strip has width h: the error about halves with h
    assert errors[1] < 0.6 * errors[0] and errors[2] < 0.6 * errors[1]
    assert errors[2] < 0.05


def test_half_wigley_graded_mesh_converges():
    errors = []
    for nx, nz in ((32, 8), (64, 16), (128, 32)):
        r = assess_mesh(half_wigley_mesh(nx, nz, "random", seed=5, grading=0.5), lref=1.0, with_fields=False)
        errors.append(abs(r.validity["I_D"].value / WIGLEY_ID - 1))
    assert errors[0] > errors[1] > errors[2] and errors[2] < 0.04


def test_scale_invariance():
    V, F = half_wigley_mesh(40, 10, "random", grading=0.3)
    a = assess_mesh((V, F), lref=1.0, with_fields=False)
    s = 7.3
    b = assess_mesh((V * s, F), lref=s, with_fields=False)
    for m in METRICS:
        assert b.validity[m].value == pytest.approx(a.validity[m].value, rel=1e-10, abs=1e-12)
    assert b.integrals.represented_area == pytest.approx(s * s * a.integrals.represented_area, rel=1e-12)
    c1, c2 = vertex_curvature(V, F), vertex_curvature(V * s, F)
    assert np.allclose(c2.K * s * s, c1.K, rtol=1e-10, atol=1e-12 * np.abs(c1.K).max())


@pytest.mark.parametrize("make", [lambda: torus_mesh(12, pattern="random"),
                                  lambda: half_wigley_mesh(24, 8, "alternating", grading=0.4)])
def test_orientation_reversal(make):
    V, F = make()
    a = vertex_curvature(V, F)
    b = vertex_curvature(V, F[:, ::-1])
    scale = np.abs(a.K).max()
    assert np.allclose(b.H, -a.H, rtol=0, atol=1e-12 * np.abs(a.H).max())
    assert np.allclose(b.K, a.K, rtol=0, atol=1e-12 * scale)
    assert np.allclose(b.k1, -a.k2, atol=1e-12 * np.abs(a.k1).max())
    assert np.allclose(b.normals, -a.normals, atol=1e-14)


@pytest.mark.parametrize("pattern", PATTERNS)
def test_index_rotation_invariance(pattern):
    V, F = torus_mesh(12, pattern=pattern)
    a = vertex_curvature(V, F)
    for G in (F[:, [1, 2, 0]], F[:, [2, 0, 1]], F[np.random.default_rng(0).permutation(len(F))]):
        b = vertex_curvature(V, G)
        for name in ("k1", "k2", "H", "K", "vertex_area", "mixed_area"):
            x, y = getattr(a, name), getattr(b, name)
            assert np.max(np.abs(x - y)) <= 1e-12 * np.max(np.abs(x)), name
        # principal directions are defined up to sign
        assert np.allclose(np.abs(np.einsum("ij,ij->i", a.dir1, b.dir1)), 1.0, atol=1e-10)


def test_global_values_are_area_weighted_field_sums():
    r = assess_mesh(half_wigley_mesh(48, 12, "random", grading=0.3), lref=1.0)
    f = r.fields
    A = f.weights
    ok = f.valid
    assert f.kind == "mesh-vertex"
    assert np.allclose(A, barycentric_vertex_areas(f.points, f.triangles), rtol=1e-13, atol=0)
    assert A.sum() == pytest.approx(r.integrals.represented_area, rel=1e-14)
    AK = A[ok].sum()
    assert AK == pytest.approx(r.integrals.valid_area, rel=1e-14)
    for m, q in (("I_D", f.q_D), ("I_D_plus", f.q_D_plus), ("I_D_minus", f.q_D_minus)):
        assert np.all(np.isnan(q[~ok])) and np.all(np.isfinite(q[ok]))
        assert np.sum(A[ok] * q[ok]) / AK == pytest.approx(r.validity[m].value, rel=1e-12)
    cid = f.class_id
    for k, m in enumerate(CLASS_METRICS):
        assert A[cid == k].sum() / A[cid >= 0].sum() == pytest.approx(r.validity[m].value, rel=1e-12, abs=1e-15)
    pa = f.point_arrays()
    assert np.array_equal(pa["k1"] * pa["k2"], f.K)          # K = k1 k2 (eq:mesh_hk)
    assert np.array_equal(0.5 * (pa["k1"] + pa["k2"]), f.H)  # H = (k1 + k2)/2


def test_no_valid_vertex_is_not_evaluated():
    """A single strip of quads has only boundary vertices: nothing to average over."""
    x = np.linspace(0.0, 1.0, 6)
    X, Y = np.meshgrid(x, [0.0, 0.2], indexing="ij")
    V = np.stack([X.ravel(), Y.ravel(), (X ** 2).ravel()], axis=1)
    r = assess_mesh((V, grid_faces(6, 2)), lref=1.0)
    for m in METRICS:
        rec = r.validity[m]
        assert rec.status == Status.NOT_EVALUATED and rec.value is None
    assert r.signature["I_D"] is None
    assert r.integrals.represented_area > 0 and r.integrals.valid_area == 0


def test_assessment_record():
    r = assess_mesh(torus_mesh(16, pattern="alternating"), lref=8.0)
    assert r.input["representation"] == "mesh" and r.input["format"] == "arrays"
    p = r.provenance
    assert p["backend"] == "mesh" and p["mesh_counts"]["faces"] == 2 * 16 * 48
    assert p["quality"]["advisory"] in ("good", "caution")
    assert p["orientation"]["orientation_changed"] is False
    assert set(r.timings) >= {"load_s", "quality_s", "curvature_s", "signature_s", "total_s"}
    doc = r.to_dict()
    assert doc["validity"]["I_D"]["status"] == "VALID"
    assert doc["validity"]["I_D"]["evidence"]["quality_advisory"] == p["quality"]["advisory"]
    r.to_json()  # strict JSON: no NaN anywhere


def test_face_tensor_fit_is_the_exact_least_squares_solution():
    """Irregular triangles (sum u v != 0) with arbitrary normals: the closed-form solution of
    the 3x3 normal equations equals numpy's least-squares solution of the 6 x 3 system."""
    from hullprod_wb.mesh.curvature import face_tensors
    rng = np.random.default_rng(7)
    m = 200
    V = rng.normal(size=(3 * m, 3)) * [1.0, 1.0, 0.3]
    F = np.arange(3 * m).reshape(m, 3)
    N = rng.normal(size=(3 * m, 3))
    N /= np.linalg.norm(N, axis=1)[:, None]
    t, b, abc = face_tensors(V, F, N)
    P = V[F]
    for f in range(m):
        rows, rhs = [], []
        for j in range(3):
            head, tail = (j + 2) % 3, (j + 1) % 3
            e = P[f, head] - P[f, tail]
            dn = N[F[f, head]] - N[F[f, tail]]
            u, v = e @ t[f], e @ b[f]
            rows += [[u, v, 0.0], [0.0, u, v]]
            rhs += [dn @ t[f], dn @ b[f]]
        x = np.linalg.lstsq(np.array(rows), np.array(rhs), rcond=None)[0]
        assert np.allclose(abc[f], x, rtol=1e-9, atol=1e-9 * np.abs(x).max())
    assert np.allclose(np.einsum("ij,ij->i", t, b), 0.0, atol=1e-14)


def test_face_facing_against_its_vertex_normal_stays_finite():
    """A tiny triangle folded back over a large one dominates the Max normal at the shared
    vertex, so the large face's normal is opposite to that vertex normal: its tensor is
    carried by a half turn instead of the (undefined) minimal rotation."""
    V = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0.01, 0.0, 0.0], [0.0, 0.01, 0.0]], dtype=float)  # coplanar: exactly opposite
    F = np.array([[0, 1, 2], [0, 4, 3]])
    c = vertex_curvature(V, F)
    assert np.dot(c.normals[0], [0, 0, 1]) < -0.99
    assert np.all(np.isfinite(c.k1)) and np.all(np.isfinite(c.k2))
