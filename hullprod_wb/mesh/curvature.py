"""Per-vertex curvature of a triangle mesh by the curvature-tensor method of Rusinkiewicz
(2004) (paper section 4.2, eq:mesh_hk, eq:vertex_area).

1. Vertex normals with the weights of Max (1999): at the corner of face f between edges
   e_a and e_b, n_i += (e_a x e_b) / (|e_a|^2 |e_b|^2), then normalised.
2. Per face an orthonormal frame (t, b) in the face plane, t along edge 0, and a least-
   squares fit of the symmetric tensor [[a, b], [b, c]] to the three edges e_j and the
   differences of the vertex normals along them, dn_j = n_head - n_tail:
   [u_j v_j 0; 0 u_j v_j] [a b c]^T = [dn_j.t; dn_j.b]  (6 equations, 3 unknowns), solved
   exactly through its 3x3 normal equations (closed-form inverse of the symmetric
   positive-definite matrix; edges are divided by a per-face length first so that the
   system is scale-free).
3. Each face tensor is carried to the frame (u_i, v_i) of each of its vertices: the face
   frame is rotated about n_f x n_i so that its normal becomes n_i, then the tensor is
   expressed in (u_i, v_i). Vertex tensors are the averages with the mixed Voronoi corner
   areas of Meyer et al. (2003) (Voronoi for non-obtuse triangles; A/2 at an obtuse corner
   and A/4 at the other two).
4. The fitted tensor is the derivative of the normal, dn = W dx; the shape operator in the
   convention of the BRep backend (second fundamental form e = n.S_uu, eq:brephk) is -W.
   Eigen-decomposition of -W per vertex: k1 >= k2 and principal directions;
   H = (k1 + k2)/2, K = k1 k2 (eq:mesh_hk).

Both realizations therefore share one sign convention: with the normals oriented along the
face winding and pointing out of a sphere, k1 = k2 = -1/R and H = -1/R, as for a BRep sphere
face with its outward normal; reversing the winding flips k1, k2 and H and keeps K. Everything is vectorised over faces (three
passes over the corner slots) and accumulated per vertex with np.bincount.
"""
from dataclasses import dataclass

import numpy as np

from ..core.errors import InputError
from ..core.threads import blocks, default_threads, iter_parts, run_blocks
from .topology import vertex_flags


@dataclass
class MeshCurvature:
    """Per-vertex curvature of a triangle mesh.

    normals, dir1, dir2: (n, 3) float unit vectors (dir1 along k1, dir2 = normals x dir1);
    k1, k2, H, K: (n,) float, NaN at vertices without a usable face; boundary: (n,) bool,
    on an edge used by exactly one face; nonmanifold: (n,) bool, on an edge used by more
    than two faces; vertex_area: (n,) float barycentric areas A_i (eq:vertex_area);
    mixed_area: (n,) float sums of the mixed Voronoi corner areas (averaging weights).
    """

    normals: np.ndarray
    k1: np.ndarray
    k2: np.ndarray
    H: np.ndarray
    K: np.ndarray
    dir1: np.ndarray
    dir2: np.ndarray
    boundary: np.ndarray
    nonmanifold: np.ndarray
    vertex_area: np.ndarray
    mixed_area: np.ndarray

    @property
    def finite(self):
        """(n,) bool, vertices where k1 and k2 are finite."""
        return np.isfinite(self.k1) & np.isfinite(self.k2)


#: A triangle with 2A <= DEGENERATE_RTOL * (longest edge)^2 (smallest altitude below this
#: fraction of the longest edge) is degenerate: it has no usable normal or frame.
DEGENERATE_RTOL = 1e-12


def check_arrays(vertices, faces, where="the mesh"):
    """Validate and convert (n, 3) float vertices and (m, 3) int faces (InputError otherwise)."""
    try:
        V = np.asarray(vertices, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise InputError("%s: vertex or face arrays cannot be read as numbers: %s" % (where, exc)) from None
    if V.ndim != 2 or V.shape[1] != 3:
        raise InputError("%s: vertices must be an (n, 3) array, got shape %s" % (where, V.shape))
    F = check_faces(faces, len(V), where)
    check_finite(V, where)
    return V, F


def check_finite(V, where="the mesh"):
    """InputError naming the vertices (rows of 3 coordinates, the last axis of V) that are
    NaN or infinite."""
    if not np.isfinite(V).all():
        bad = ~np.isfinite(V).all(axis=-1)
        raise InputError("%s has NaN or infinite coordinates at %d of its %d vertices"
                         % (where, int(np.count_nonzero(bad)), bad.size))


def check_faces(faces, n, where="the mesh"):
    """(m, 3) int64 faces of vertex ids 0..n-1 (InputError otherwise)."""
    try:
        F = np.asarray(faces)
    except (TypeError, ValueError) as exc:
        raise InputError("%s: vertex or face arrays cannot be read as numbers: %s" % (where, exc)) from None
    if F.ndim != 2 or F.shape[1] != 3:
        raise InputError("%s: faces must be an (m, 3) array of vertex indices, got shape %s"
                         % (where, F.shape))
    if F.size and not np.issubdtype(F.dtype, np.integer):
        if not np.all(np.mod(F, 1) == 0):
            raise InputError("%s: faces must hold integer vertex indices" % where)
    F = F.astype(np.int64, copy=False)
    if F.size and (F.min() < 0 or F.max() >= n):
        raise InputError("%s: faces refer to vertex indices outside 0..%d" % (where, n - 1))
    return F


def _dot(a, b):
    """Row-wise dot product of (3, m) arrays."""
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def _cross(a, b):
    """Cross product of (3, m) arrays."""
    return np.stack([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]])


def _vertex_sums(index, weights, n, threads):
    """Per-vertex sums over the three corner slots: out[k] = sum over j of
    bincount(index[j], weights[k][j]) for each weight row k ((3, m) index rows, weights
    (k, 3, m)); the bincounts run on threads, the sums in the slot order 0, 1, 2, each row's
    as soon as its three bincounts are done."""
    jobs = [(k, j) for k in range(len(weights)) for j in range(3)]

    def count(kj):
        return np.bincount(index[kj[1]], weights=weights[kj[0]][kj[1]], minlength=n)
    parts = iter_parts([lambda kj=kj: count(kj) for kj in jobs], threads)
    return [sum(next(parts) for _ in range(3)).astype(float, copy=False) for _ in range(len(weights))]


def barycentric_vertex_areas(vertices, faces):
    """A_i = (1/3) sum of the areas of the faces incident to vertex i (eq:vertex_area), (n,)."""
    V, F = check_arrays(vertices, faces)
    P = V[F]
    A = 0.5 * np.linalg.norm(np.cross(P[:, 1] - P[:, 0], P[:, 2] - P[:, 0]), axis=1)
    return np.bincount(F.ravel(), weights=np.repeat(A / 3.0, 3), minlength=len(V))


def frame_u(normals, out):
    """u of the orthonormal tangent frames (u, v = n x u) of (3, n) unit normals, written
    into out (3, n).

    u is the coordinate axis least aligned with n, made orthogonal to n; the choice
    depends on the normal only, so the results do not depend on the face order.
    """
    a0, a1, a2 = np.abs(normals)
    first = (a0 <= a1) & (a0 <= a2)        # the first axis of least |n_i|, as argmin picks it
    second = ~first & (a1 <= a2)
    np.copyto(out[0], first)
    np.copyto(out[1], second)
    np.copyto(out[2], ~first & ~second)
    out -= normals * _dot(out, normals)
    out /= np.sqrt(_dot(out, out))
    return out


#: Faces per block of the vectorised passes: the temporaries of one block stay in cache.
BLOCK = 1 << 16


def _take(rows, index):
    """Gather columns index of a (k, n) array: (k, b) contiguous (np.take is several times
    faster than fancy indexing along the second axis)."""
    return np.take(rows, index, axis=1)


def _face_geometry(Vt, f0, f1, f2):
    """Edges e0 (corner 1 -> 2), e1 (2 -> 0), e2 (0 -> 1), their squared lengths, the
    doubled-area normal N = e1 x e2 = 2 A n_f, |N| and the usable-face mask (3, b) / (b,)."""
    p0, p1, p2 = _take(Vt, f0), _take(Vt, f1), _take(Vt, f2)
    e0 = p2 - p1
    e1 = p0 - p2
    e2 = np.subtract(p1, p0, out=p1)
    l0, l1, l2 = _dot(e0, e0), _dot(e1, e1), _dot(e2, e2)
    N = _cross(e1, e2)
    dblA = np.sqrt(_dot(N, N))
    good = dblA > DEGENERATE_RTOL * np.maximum(np.maximum(l0, l1), l2)  # degenerate: ignored
    return e0, e1, l0, l1, l2, N, dblA, good


def _corner_areas(l0, l1, l2, area):
    """Mixed Voronoi corner areas of Meyer et al. (3 arrays (b,)).

    ew_j = l_j (l_{j+1} + l_{j+2} - l_j) = 4 A |e_j|^2 cot(angle j): non-obtuse triangles
    give corner j the Voronoi area (A/2)(ew_{j+1} + ew_{j+2}) / sum(ew); a triangle with
    an angle >= 90 degrees (ew_j <= 0) gives A/2 to that corner and A/4 to the others.
    """
    s = l0 + l1 + l2
    ew = [lj * (s - 2.0 * lj) for lj in (l0, l1, l2)]
    ewsum = ew[0] + ew[1] + ew[2]
    big = [e <= 0 for e in ew]
    obtuse = np.flatnonzero(big[0] | big[1] | big[2])
    ewsum[obtuse] = 1.0
    vor = (0.5 * area) / ewsum
    out = []
    for j in range(3):
        cj = vor * (ewsum - ew[j])
        cj[obtuse] = area[obtuse] * np.where(big[j][obtuse], 0.5, 0.25)
        out.append(cj)
    return out


def _normal_block(Vt, fc, cn, area, sl):
    """Max (1999) weights of one block: corner j lies between the two edges other than
    e_j, n_i += N / (|e_a|^2 |e_b|^2) = N l_j / (l0 l1 l2); also the face areas."""
    _, _, l0, l1, l2, N, dblA, good = _face_geometry(Vt, fc[0][sl], fc[1][sl], fc[2][sl])
    inv = np.zeros_like(dblA)
    np.divide(1.0, l0 * l1 * l2, out=inv, where=good)
    for j, lj in enumerate((l0, l1, l2)):
        np.multiply(N, lj * inv, out=cn[j][:, sl])
    np.multiply(dblA, 0.5 * good, out=area[sl])


def _fit(Vt, rows, f):
    """Face frames and the exact least-squares tensors of the faces f = (f0, f1, f2).

    rows: (k, n) vertex data whose first three rows are the unit normals. Returns the face
    geometry, frames t, b, n_f (3, b), the gathered vertex rows per corner, n_i.t and n_i.b
    per corner, the tensor (ta, tb, tc) in (t, b) and the mask of fitted faces.
    """
    e0, e1, l0, l1, l2, N, dblA, good = _face_geometry(Vt, *f)
    sl0 = np.sqrt(l0)
    gi = 1.0 - good
    t = e0 / (sl0 + gi)
    nf = N / (dblA + gi)
    bf = _cross(nf, t)
    vert = [_take(rows, fj) for fj in f]
    nt = [_dot(g[0:3], t) for g in vert]
    nb = [_dot(g[0:3], bf) for g in vert]
    sinv = 1.0 / (np.sqrt(l0 + l1 + l2) + gi)
    u0 = sl0 * sinv
    u1 = _dot(e1, t) * sinv
    v1 = _dot(e1, bf) * sinv
    u2 = -(u0 + u1)                       # e0 + e1 + e2 = 0, e0 along t
    # dn_j = n(corner j+2) - n(corner j+1) in the face frame
    dnu0, dnu1, dnu2 = nt[2] - nt[1], nt[0] - nt[2], nt[1] - nt[0]
    dnv0, dnv1, dnv2 = nb[2] - nb[1], nb[0] - nb[2], nb[1] - nb[0]
    p = u0 * u0 + u1 * u1 + u2 * u2
    r = 2.0 * v1 * v1
    s = (u1 - u2) * v1
    m0 = dnu0 * u0 + dnu1 * u1 + dnu2 * u2
    m1 = (dnu1 - dnu2) * v1 + dnv0 * u0 + dnv1 * u1 + dnv2 * u2
    m2 = (dnv1 - dnv2) * v1
    # Normal equations W x = m, W = [[p, s, 0], [s, p + r, s], [0, s, r]]:
    # det W = (p + r)(p r - s^2) > 0 for a non-degenerate face; x = adj(W) m / det W.
    q = p + r
    ss = s * s
    pr = p * r
    det = q * (pr - ss)
    ok = good & (det > 0)
    idet = np.zeros_like(det)
    np.divide(sinv, det, out=idet, where=ok)  # sinv undoes the edge scaling
    sr = s * r
    ps = p * s
    ta = ((q * r - ss) * m0 - sr * m1 + ss * m2) * idet
    tb = (pr * m1 - sr * m0 - ps * m2) * idet
    tc = (ss * m0 - ps * m1 + (p * q - ss) * m2) * idet
    return (l0, l1, l2, dblA), (t, bf, nf), vert, nt, nb, (ta, tb, tc), ok


def face_tensors(vertices, faces, normals):
    """Per-face least-squares curvature tensors (step 2 of the module docstring).

    vertices (n, 3), faces (m, 3), unit vertex normals (n, 3). Returns t, b (m, 3), the
    orthonormal face frame (t along the edge from corner 1 to corner 2), and (m, 3)
    components (a, b, c) of [[a, b], [b, c]] in that frame; zeros for degenerate faces.
    """
    V, F = check_arrays(vertices, faces)
    nrm = np.ascontiguousarray(np.asarray(normals, dtype=float).T)
    _, (t, bf, _), _, _, _, abc, _ = _fit(np.ascontiguousarray(V.T), nrm, [F[:, j] for j in range(3)])
    return t.T, bf.T, np.stack(abc, axis=1)


def _tensor_block(Vt, fc, frames, acc, sl):
    """Face frame, exact least-squares tensor and its transport to the three corners of
    one block; writes corner-area weighted (mean, X, Y, weight) into acc[:, j, sl]."""
    f = [fc[j][sl] for j in range(3)]
    (l0, l1, l2, dblA), (t, bf, nf), vert, nt, nb, (ta, tb, tc), ok = _fit(Vt, frames, f)
    corner = _corner_areas(l0, l1, l2, dblA * (0.5 * ok))
    # Rotating the face frame within the tangent planes keeps the trace and turns the
    # deviator (dev, tb), dev = (ta - tc)/2, by the frame angle: with (al, be) = (cos, sin)
    # of that angle, kuu = mean + X, kvv = mean - X, kuv = Y, where
    # X = dev cos 2phi + tb sin 2phi and Y = tb cos 2phi - dev sin 2phi.
    mean = 0.5 * (ta + tc)
    dev = 0.5 * (ta - tc)
    for j in range(3):
        # The rotation about n_i x n_f taking n_i to n_f maps a vector x of the vertex
        # plane to x - (x.n_f) (n_i + n_f) / (1 + c), c = n_i.n_f. It is the inverse of the
        # rotation taking the face frame to the vertex normal, so with u' the image of u_i,
        # al = u_i.(R t) = u'.t and be = u_i.(R b) = u'.b.
        g = vert[j]
        c = _dot(g[0:3], nf)
        uj = g[3:6]
        un, ut, ub = _dot(uj, nf), _dot(uj, t), _dot(uj, bf)
        opp = ~(c > 1e-12 - 1.0)          # opposite normals: half turn about t instead
        h = un / (1.0 + c + opp)
        al = ut - nt[j] * h
        be = ub - nb[j] * h
        if opp.any():
            al[opp] = ut[opp]
            be[opp] = -ub[opp]
        cos2 = al * al - be * be
        sin2 = 2.0 * al * be
        w = corner[j]
        np.multiply(w, mean, out=acc[0, j, sl])
        np.multiply(w, dev * cos2 + tb * sin2, out=acc[1, j, sl])
        np.multiply(w, tb * cos2 - dev * sin2, out=acc[2, j, sl])
        acc[3, j, sl] = w


def vertex_curvature(vertices, faces, threads=None, flags=None, rows=None):
    """Rusinkiewicz (2004) curvature at every vertex (see module docstring).

    vertices: (n, 3) float; faces: (m, 3) int, oriented. Degenerate faces (see
    DEGENERATE_RTOL) are ignored. threads: worker threads for the block passes (default
    :func:`default_threads`). flags: (boundary, nonmanifold) (n,) bool vertex flags when
    known already (topology.EdgeTable.vertex_flags), else found here. rows: the (3, n)
    contiguous coordinate rows of the vertices when at hand
    (face_geometry.coordinate_rows). Returns a MeshCurvature.
    """
    V, F = check_arrays(vertices, faces)
    n, m = len(V), len(F)
    threads = default_threads() if threads is None else max(1, int(threads))
    Vt = np.ascontiguousarray(V.T) if rows is None else rows
    fc = [np.ascontiguousarray(F[:, j]) for j in range(3)]
    face_blocks = blocks(m, BLOCK)

    # 1. Max (1999) vertex normals and the face areas.
    # one buffer for the corner normals and then the corner tensors: its pages are
    # faulted in once
    buffer = np.empty(12 * m)
    cn = buffer[:9 * m].reshape(3, 3, m)      # corner slot, coordinate, face
    area = np.empty(m)
    run_blocks(lambda sl: _normal_block(Vt, fc, cn, area, sl), face_blocks, threads)
    frames = np.empty((6, n))                 # (6, n): normal, u
    nv, uf = frames[:3], frames[3:]
    for c, total in enumerate(_vertex_sums(fc, [[cn[j][c] for j in range(3)] for c in range(3)], n, threads)):
        nv[c] = total
    del cn
    has_normal = np.empty(n, dtype=bool)
    vertex_blocks = blocks(n, BLOCK)
    run_blocks(lambda sl: _frame_block(nv, uf, has_normal, sl), vertex_blocks, threads)

    # 2-3. Face tensors carried to the corners, accumulated with the corner areas.
    acc = buffer.reshape(4, 3, m)
    run_blocks(lambda sl: _tensor_block(Vt, fc, frames, acc, sl), face_blocks, threads)
    kmean, kx, ky, wsum = _vertex_sums(fc, acc, n, threads)
    del acc, buffer

    # 4. Eigen-decomposition of the vertex tensors [[mean + X, Y], [Y, mean - X]].
    out = {name: np.empty(n) for name in ("k1", "k2", "H", "K")}
    d1, d2 = np.empty((3, n)), np.empty((3, n))
    run_blocks(lambda sl: _eigen_block(nv, uf, has_normal, (kmean, kx, ky, wsum), out, d1, d2, sl),
               vertex_blocks, threads)
    boundary, nonmanifold = vertex_flags(F, n) if flags is None else flags
    vertex_area = _vertex_sums(fc, [[area] * 3], n, threads)[0] / 3.0
    return MeshCurvature(normals=nv.T, k1=out["k1"], k2=out["k2"], H=out["H"], K=out["K"], dir1=d1.T,
                         dir2=d2.T, boundary=boundary, nonmanifold=nonmanifold,
                         vertex_area=vertex_area, mixed_area=wsum)


def _frame_block(nv, uf, has_normal, sl):
    """Normalise the summed vertex normals nv[:, sl] and write the frame vectors uf[:, sl]
    (frame_u; the z axis stands in for a vertex without a normal)."""
    n_sl = nv[:, sl]
    nlen = np.sqrt(_dot(n_sl, n_sl))
    has = has_normal[sl] = nlen > 0
    n_sl /= np.where(has, nlen, 1.0)
    frame_u(np.where(has, n_sl, [[0.0], [0.0], [1.0]]), uf[:, sl])


def _eigen_block(nv, uf, has_normal, sums, out, d1, d2, sl):
    """Principal curvatures and directions of the vertices sl from the corner-area weighted
    tensor sums (kmean, kx, ky, wsum) (step 4 of the module docstring); NaN normals where a
    vertex has none."""
    kmean, kx, ky, wsum = (a[sl] for a in sums)
    has = has_normal[sl]
    u = uf[:, sl]
    v = _cross(np.where(has, nv[:, sl], [[0.0], [0.0], [1.0]]), u)
    usable = has & (wsum > 0)
    wi = np.where(usable, 1.0 / np.where(usable, wsum, 1.0), np.nan)
    kmean *= -wi  # shape operator -W: the sign convention of eq:brephk
    kx *= -wi
    ky *= -wi
    rad = np.hypot(kx, ky)
    k1 = out["k1"][sl] = kmean + rad
    k2 = out["k2"][sl] = kmean - rad
    out["H"][sl] = 0.5 * (k1 + k2)
    out["K"][sl] = k1 * k2
    theta = 0.5 * np.arctan2(ky, kx)
    ct, st = np.cos(theta), np.sin(theta)
    d1[:, sl] = ct * u + st * v
    d2[:, sl] = ct * v - st * u
    nv[:, sl][:, ~has] = np.nan
