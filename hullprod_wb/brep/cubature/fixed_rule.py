"""Fixed tensor Gauss-Legendre rules on the boundary-fitted patches, without refinement:
independent checks of the adaptive cubature (patch_rule, patch_area), and the patch groups
in which a face of many patches is integrated (patch_groups)."""
import numpy as np

from ...core.errors import InputError
from .gauss_rules import gauss_rule
from .patches import Patches, check_domain
from .cells import cell_nodes, tensor_cells, values_at_nodes
from .driver import Integration
from .settings import GROUPS, GROUP_MIN_PATCHES, QUANTITIES


def patch_rule(domain, field, order, u_breaks=(), v_breaks=()):
    """Integrals of QUANTITIES by the fixed tensor Gauss-Legendre rule of the given order
    (>= 3) on every boundary-fitted patch of the domain, without refinement (an independent
    check of the adaptive cubature; class quantities with unit thresholds), and the summed
    embedded-rule differences (gauss_rules.embedded_weights) as a bound on their error: two dicts
    quantity -> float."""
    check_domain("patch_rule", domain)
    if int(order) < 3:
        raise InputError("patch_rule() needs order >= 3, got %r" % (order,))
    it = Integration(domain, field, 1.0, 1.0, int(order), 1.0, 0, u_breaks, v_breaks, None)
    values = {q: float(x) for q, x in zip(QUANTITIES, it.active.Q.sum(0))}
    bounds = {q: float(x) for q, x in zip(QUANTITIES, it.active.err_e.sum(0))}
    return values, bounds


def patch_area(domain, area_element, order, u_breaks=(), v_breaks=(), area_element_grid=None):
    """Represented area by the fixed tensor Gauss-Legendre rule of the given order (>= 3) on
    every boundary-fitted patch of the domain (the nodes and weights of patch_rule), from
    area_element(u, v) -> dict with J alone (and area_element_grid(u, v), the same on tensor
    grids as FaceField.area_element_grid, for the patches between constant bounds), and the
    summed embedded-rule differences as a bound on its error: (area, bound)."""
    check_domain("patch_area", domain)
    order = int(order)
    if order < 3:
        raise InputError("patch_area() needs order >= 3, got %r" % (order,))
    x, w, we = gauss_rule(order)
    patches = Patches.of(domain, u_breaks, v_breaks)
    n = patches.size
    zero, one = np.zeros(n), np.ones(n)
    pid = np.arange(n)
    U, V, du, lo, hi = cell_nodes(patches, pid, zero, one, zero, one, x)
    grid = None if area_element_grid is None else (
        lambda u, v: (np.asarray(area_element_grid(u, v)["J"], dtype=float).ravel(),))
    J, = values_at_nodes(lambda u, v: (np.asarray(area_element(u.ravel(), v.ravel())["J"], dtype=float).ravel(),),
                         grid, tensor_cells(patches, pid), U, V)
    J = np.where(np.isfinite(J), J, 0.0)  # as the cubature's fields: no area where J is undefined
    G = (du * (hi - lo))[:, :, None] * J  # the patch map's Jacobian times J at the nodes
    area = np.einsum("cij,i,j->c", G, w, w)
    bound = np.abs(area - np.einsum("cij,i,j->c", G, we, we))
    return float(area.sum()), float(bound.sum())


def patch_groups(n_patches, min_patches=None):
    """Patch index ranges [(start, stop), ...] in which a face of n_patches boundary-fitted
    patches is integrated: GROUPS consecutive ranges of equal size when the face has at least
    min_patches (default GROUP_MIN_PATCHES), else the whole face. It depends on the geometry
    only, so the values do not depend on how many processes integrate the groups."""
    n = int(n_patches)
    g = GROUPS if n >= (GROUP_MIN_PATCHES if min_patches is None else min_patches) else 1
    cuts = [(k * n) // g for k in range(g + 1)]
    return [(a, b) for a, b in zip(cuts[:-1], cuts[1:])]
