"""Quadrature rules on [0, 1] used by the adaptive cubature (hullprod_wb.brep.cubature):
Gauss-Legendre nodes and weights, the embedded lower-degree rule on the Gauss nodes, the
Gauss-Kronrod 3/7 pair, and weights integrating the interpolant of samples over a piece.
"""
import functools

import numpy as np


def legendre_vander(z, deg):
    """Legendre-Vandermonde matrix (n, deg + 1) of z (n,) in [-1, 1]: P_k(z) by the
    three-term recurrence k P_k = (2k - 1) z P_(k-1) - (k - 1) P_(k-2). Each degree is
    written as one contiguous row of a (deg + 1, n) array and the transpose is returned
    (a column-major view): writing the columns of a row-major array instead strides through
    memory and costs several times more on large n."""
    z = np.asarray(z, dtype=float).ravel()
    V = np.empty((deg + 1, z.size))
    V[0] = 1.0
    if deg > 0:
        V[1] = z
    for k in range(2, deg + 1):
        V[k] = ((2 * k - 1) * z * V[k - 1] - (k - 1) * V[k - 2]) / k
    return V.T


def embedded_weights(x):
    """Weights (n,) on the Gauss nodes x (n,) of [0, 1] of the interpolatory rule on all
    of them but the middle one (n odd; for n even, the one left of the middle), exact to
    degree n - 2, with a zero weight on the dropped node: the embedded lower-order rule whose
    difference to the Gauss rule bounds its error. None for n < 3."""
    n = x.size
    if n < 3:
        return None
    keep = np.ones(n, bool)
    keep[(n - 1) // 2] = False
    xs = x[keep]
    k = np.arange(n - 1)
    moments = 1.0 / (k + 1)  # int_0^1 x^k
    w = np.zeros(n)
    w[keep] = np.linalg.solve(np.vander(xs, n - 1, increasing=True).T, moments)
    return w


def gauss_nodes(order):
    """Gauss-Legendre nodes and weights on [0, 1], (order,) each."""
    x, w = np.polynomial.legendre.leggauss(order)
    return 0.5 * (x + 1.0), 0.5 * w


@functools.lru_cache(maxsize=None)
def gauss_rule(order):
    """(x, w, w_embedded): gauss_nodes(order) and their embedded_weights, made once an
    order (an eigenvalue problem and a solve; every integration takes them), read-only."""
    x, w = gauss_nodes(order)
    return read_only(x), read_only(w), read_only(embedded_weights(x))


def read_only(a):
    """The array a (or None) made read-only: for the rules and matrices made once and shared."""
    if a is not None:
        a.setflags(write=False)
    return a


def _symmetric(x_pos):
    """Nodes of [-1, 1] (sorted) from their non-negative half."""
    x_pos = np.asarray(x_pos, dtype=float)
    return np.sort(np.concatenate((-x_pos[x_pos > 0.0], x_pos)))


def kronrod(x_pos, gauss_pos):
    """Gauss-Kronrod rule on [0, 1] from the non-negative nodes x_pos of [-1, 1], of which
    gauss_pos are the Gauss nodes: nodes (m,), Kronrod weights (m,) solving the moment
    equations of the nodes, Gauss weights (m,) (zero at the Kronrod-only nodes)."""
    x = _symmetric(x_pos)
    m = x.size
    k = np.arange(m)
    moments = (1.0 - (-1.0) ** (k + 1)) / (k + 1)
    wk = np.linalg.solve(np.vander(x, m, increasing=True).T, moments)
    gx = _symmetric(gauss_pos)
    wg = np.zeros(m)
    wg[np.searchsorted(x, gx - 1e-12)] = np.polynomial.legendre.leggauss(gx.size)[1]
    return 0.5 * (x + 1.0), 0.5 * wk, 0.5 * wg


#: Gauss-Kronrod 3/7 (exact to degree 11) in sigma along the lines of a piece.
XK, WK, WG = kronrod([0.0, 0.4342437493468026, 0.7745966692414834, 0.9604912687080202],
                      [0.0, 0.7745966692414834])

def piece_weights(nodes):
    """(m+1, m) matrix M: for a piece [za, zb] of [0, 1], 0.5 (P(2 zb - 1) - P(2 za - 1)) M
    with P the Legendre-Vandermonde rows of degree m gives the weights (m,) of the samples
    at nodes (m,) that integrate their interpolating polynomial over the piece."""
    m = nodes.size
    V = np.polynomial.legendre.legvander(2.0 * nodes - 1.0, m - 1)
    A = np.stack([np.polynomial.legendre.legint(np.eye(m)[j]) for j in range(m)], 1)
    return A @ np.linalg.inv(V)


def kronrod_error(F, Fk):
    """Error estimate |K7 - G3| (n, q) of Gauss-Kronrod 3/7 sums Fk = sum_k WK_k F_k from
    the node values F (n, 7, q) (on [0, 1], Jacobians included): the error of the nested
    3-point rule, a safe bound for the 7-point one."""
    return np.abs(Fk - np.einsum("nkq,k->nq", F, WG))
