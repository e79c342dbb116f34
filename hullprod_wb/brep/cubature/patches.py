"""Boundary-fitted patches of a trimmed parameter domain (paper eq:brep_surface_integral).

u is cut at the domain's breakpoints, at the knot lines u_breaks and where the trim curves
cross the knot lines v_breaks. In each slab every strip lo(u) <= v <= hi(u) (further cut at
the v_breaks inside it) is a patch mapped from the unit square,
    u = u(sigma),  v = lo(u) + t (hi(u) - lo(u)),   du dv = u'(sigma) (hi - lo) dsigma dt,
with u(sigma) affine, or clustered like u - u0 ~ sigma^2 by a cosine map (cluster_map) next
to a slab end where a trim curve has a vertical tangent, so that strip widths ~ sqrt(u - u0)
become smooth in sigma.
"""
import numpy as np

from ...core.errors import InputError


def cluster_map(kind, x):
    """Map of [0, 1] onto itself and its derivative, (same shapes as x).

    kind 0: x; 1: 1 - cos(pi x / 2), clustered at 0 (c ~ x^2); 2: sin(pi x / 2), clustered
    at 1; 3: (1 - cos(pi x)) / 2, clustered at both ends. A function with a square-root
    end, f(c) ~ sqrt(c), becomes smooth in x; for a circle's strip width, trigonometric.
    """
    kind, x = np.broadcast_arrays(np.asarray(kind), np.asarray(x, dtype=float))
    c, dc = x.copy(), np.ones(x.shape)
    if not kind.any():  # all affine: the common case
        return c, dc
    h = 0.5 * np.pi
    for k in (1, 2, 3):  # each map on its own points only
        i = np.nonzero(kind == k)
        if i[0].size == 0:
            continue
        xi = x[i]
        if k == 1:
            c[i], dc[i] = 1.0 - np.cos(h * xi), h * np.sin(h * xi)
        elif k == 2:
            c[i], dc[i] = np.sin(h * xi), h * np.cos(h * xi)
        else:
            c[i], dc[i] = 0.5 * (1.0 - np.cos(np.pi * xi)), h * np.sin(np.pi * xi)
    return c, dc


#: What the patches read of a trimmed domain (geometry.trimmed_domain.TrimmedDomain).
DOMAIN_ATTRIBUTES = ("u_range", "v_range", "snap_tol", "breakpoints", "slabs", "u_breakpoints",
                     "v_line_crossings", "piece_turns", "piece_u_lo", "piece_u_hi", "piece_v", "piece_const_v")


def check_domain(caller, domain):
    """InputError unless domain has what the patches read of a TrimmedDomain."""
    if not all(hasattr(domain, a) for a in DOMAIN_ATTRIBUTES):
        raise InputError("%s() needs a TrimmedDomain, got %s" % (caller, type(domain).__name__))


class Patches:
    """Unit-square patches (sigma, t) of a trimmed domain (see the module docstring).

    Arrays (P,): u0, u1, umap (cluster_map kind: 1 clustered at u0, 2 at u1, 3 both), lo_piece,
    hi_piece (piece index of the domain, -1 for a constant), lo_v, hi_v (the constants).
    """

    def __init__(self, domain, u_breaks, v_breaks):
        self.domain = domain
        tol = domain.snap_tol
        ur = domain.u_range
        vb = np.unique(np.asarray(v_breaks, dtype=float).ravel())
        vb = vb[(vb > domain.v_range[0]) & (vb < domain.v_range[1])]
        cuts = [domain.u_breakpoints(), np.asarray(u_breaks, dtype=float).ravel(),
                domain.v_line_crossings(vb)]
        cuts = np.unique(np.concatenate(cuts))
        cuts = cuts[(cuts >= ur[0]) & (cuts <= ur[1])]
        keep = np.concatenate(([True], np.diff(cuts) > tol))
        cuts = cuts[keep]
        dom_bp = domain.breakpoints
        slabs = []  # (a, b, lo pieces, hi pieces, kind) of each slab between cuts
        for a, b in zip(cuts[:-1], cuts[1:]):
            k = min(max(np.searchsorted(dom_bp, 0.5 * (a + b)) - 1, 0), len(domain.slabs) - 1)
            _, _, lo_p, hi_p = domain.slabs[k]
            if lo_p.size == 0:
                continue
            # an end is clustered when a bounding piece has a vertical tangent there
            act = np.concatenate((lo_p, hi_p))
            ta = np.any(domain.piece_turns[act, 0] & (np.abs(domain.piece_u_lo[act] - a) <= tol))
            tb = np.any(domain.piece_turns[act, 1] & (np.abs(domain.piece_u_hi[act] - b) <= tol))
            slabs.append((a, b, lo_p, hi_p, (1 if ta else 0) + (2 if tb else 0)))
        # the bounding pieces at the slabs' mid-lines, one evaluation per piece for all its slabs
        mids = {}
        for i, (a, b, lo_p, hi_p, _) in enumerate(slabs):
            for p in np.concatenate((lo_p, hi_p)):
                mids.setdefault(int(p), []).append(i)
        at_mid = {}
        for p, idx in mids.items():
            um = np.array([0.5 * (slabs[i][0] + slabs[i][1]) for i in idx])
            for i, v in zip(idx, domain.piece_v(p, um)):
                at_mid[p, i] = v
        rows = []
        for i, (a, b, lo_p, hi_p, kind) in enumerate(slabs):
            lo_m = np.array([at_mid[int(p), i] for p in lo_p])
            hi_m = np.array([at_mid[int(p), i] for p in hi_p])
            pieces = []
            for lp, hp, lv, hv in zip(lo_p, hi_p, lo_m, hi_m):
                inner = vb[(vb > lv + tol) & (vb < hv - tol)]
                bnd_p = np.concatenate(([lp], np.full(inner.size, -1), [hp]))
                bnd_v = np.concatenate(([np.nan], inner, [np.nan]))
                for j in range(bnd_p.size - 1):
                    pieces.append((bnd_p[j], bnd_v[j], bnd_p[j + 1], bnd_v[j + 1]))
            for (lp, lv, hp, hv) in pieces:
                rows.append((a, b, kind, lp, lv, hp, hv))
        if not rows:
            raise InputError("trimmed domain has no area to integrate over")
        r = np.array(rows, dtype=float)
        self.u0, self.u1 = r[:, 0], r[:, 1]
        self.umap = r[:, 2].astype(int)
        self.lo_piece, self.hi_piece = r[:, 3].astype(int), r[:, 5].astype(int)
        cv = domain.piece_const_v
        self.lo_v = np.where(self.lo_piece >= 0, cv[np.maximum(self.lo_piece, 0)], r[:, 4])
        self.hi_v = np.where(self.hi_piece >= 0, cv[np.maximum(self.hi_piece, 0)], r[:, 6])
        # a horizontal piece is a constant boundary too
        self.lo_piece = np.where(np.isnan(self.lo_v), self.lo_piece, -1)
        self.hi_piece = np.where(np.isnan(self.hi_v), self.hi_piece, -1)

    @classmethod
    def of(cls, domain, u_breaks, v_breaks):
        """The patches of domain cut at the given breaks, built once per domain and breaks
        (kept on the domain object)."""
        ub = np.unique(np.asarray(u_breaks, dtype=float).ravel())
        vb = np.unique(np.asarray(v_breaks, dtype=float).ravel())
        key = (ub.tobytes(), vb.tobytes())
        cache = domain.__dict__.setdefault("_patch_cache", {})
        if key not in cache:
            cache[key] = cls(domain, ub, vb)
        return cache[key]

    @property
    def size(self):
        return self.u0.size

    def u_of_sigma(self, pid, sig):
        """u and du/dsigma for patch ids pid and sigma in [0, 1] (same shapes), by
        :func:`cluster_map` of the patch's kind over [u0, u1]."""
        a, w = self.u0[pid], self.u1[pid] - self.u0[pid]
        c, dc = cluster_map(self.umap[pid], sig)
        return a + w * c, w * dc

    def bounds(self, pid, u):
        """lo(u), hi(u) of the patches pid at u (same shapes)."""
        shape = u.shape
        pid, u = pid.ravel(), u.ravel()
        out = []
        for piece, const in ((self.lo_piece, self.lo_v), (self.hi_piece, self.hi_v)):
            p = piece[pid]
            val = const[pid].copy()
            for k in np.unique(p[p >= 0]):
                sel = p == k
                uu, back = np.unique(u[sel], return_inverse=True)  # lines shared by cells
                val[sel] = self.domain.piece_v(k, uu)[back]
            out.append(val.reshape(shape))
        return out[0], out[1]

    def boxes(self, pid, s0, s1, t0, t1):
        """(n, 4) [u_min, u_max, v_min, v_max] of (sigma, t) cells (v from the cell's u ends)."""
        sig = np.stack((s0, s1), 1)
        P = np.stack((pid, pid), 1)
        u, _ = self.u_of_sigma(P, sig)
        lo, hi = self.bounds(P, u)
        v0 = lo + t0[:, None] * (hi - lo)
        v1 = lo + t1[:, None] * (hi - lo)
        vv = np.concatenate((v0, v1), 1)
        return np.stack((u.min(1), u.max(1), vv.min(1), vv.max(1)), 1)
