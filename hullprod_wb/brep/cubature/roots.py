"""Vectorised bracketed root finding: Chandrupatla's method on many brackets at once."""
import numpy as np


def solve_bracketed(fun, x0, x1, f0, f1, xtol, maxiter=100):
    """Roots of fun in the brackets [x0, x1] with f0 * f1 <= 0, all at once, (n,) float.

    fun(x, index) evaluates the function at x (m,) for the brackets index (m,) int; one
    call per iteration for all brackets still active. Chandrupatla's method, started with a
    regula falsi step: inverse quadratic interpolation when the last three points allow
    it, bisection otherwise, with
    steps at least the tolerance away from the bracket ends; a bracket ends when it is
    narrower than about xtol (scalar or (n,)) + 4 eps |x|, at an exact zero, or at a
    non-finite value. Returns the bracket end of smaller |f|.
    """
    b = np.array(x0, dtype=float, copy=True).ravel()
    a = np.array(x1, dtype=float, copy=True).ravel()
    fb = np.array(f0, dtype=float, copy=True).ravel()
    fa = np.array(f1, dtype=float, copy=True).ravel()
    c, fc = a.copy(), fa.copy()
    n = a.size
    xtol = np.broadcast_to(np.asarray(xtol, dtype=float), (n,))
    # first step: regula falsi (then inverse quadratic interpolation or bisection)
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.nan_to_num(fa / (fa - fb), nan=0.5)
    tl0 = np.minimum((2.0 * np.finfo(float).eps * np.abs(a) + 0.5 * xtol)
                     / np.maximum(np.abs(b - a), 1e-300), 0.5)
    t = np.clip(t, tl0, 1.0 - tl0)
    xm = np.where(np.abs(fa) < np.abs(fb), a, b)
    active = (fa != 0.0) & (fb != 0.0)
    for _ in range(maxiter):
        i = np.nonzero(active)[0]
        if i.size == 0:
            break
        ai, bi, fai, fbi = a[i], b[i], fa[i], fb[i]
        xt = ai + t[i] * (bi - ai)
        ft = np.asarray(fun(xt, i), dtype=float)
        same = np.sign(ft) == np.sign(fai)
        ci = np.where(same, ai, bi)
        fci = np.where(same, fai, fbi)
        bi = np.where(same, bi, ai)
        fbi = np.where(same, fbi, fai)
        ai, fai = xt, ft
        better = np.abs(fai) < np.abs(fbi)
        xmi = np.where(better, ai, bi)
        fm = np.where(better, fai, fbi)
        tol = 2.0 * np.finfo(float).eps * np.abs(xmi) + 0.5 * xtol[i]
        with np.errstate(divide="ignore", invalid="ignore"):
            tl = tol / np.abs(bi - ci)
            xi = (ai - bi) / (ci - bi)
            phi = (fai - fbi) / (fci - fbi)
            iqi = (phi * phi < xi) & ((1.0 - phi) ** 2 < 1.0 - xi)
            tn = (fai / (fbi - fai) * fci / (fbi - fci)
                  + (ci - ai) / (bi - ai) * fai / (fci - fai) * fbi / (fci - fbi))
        tn = np.where(iqi & np.isfinite(tn), tn, 0.5)
        tl = np.minimum(np.nan_to_num(tl, nan=1.0), 0.5)
        a[i], b[i], c[i], fa[i], fb[i], fc[i], xm[i] = ai, bi, ci, fai, fbi, fci, xmi
        t[i] = np.clip(tn, tl, 1.0 - tl)
        active[i[(tl >= 0.5) | (fm == 0.0) | ~np.isfinite(ft)]] = False
    return xm
