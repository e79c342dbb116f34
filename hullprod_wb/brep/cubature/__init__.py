"""Adaptive boundary-fitted Gauss-Legendre cubature over a trimmed face domain
(paper eq:brep_surface_integral, section 4.1; settings of section 5.2).

Integrals over Omega, the face's trimmed (u, v) domain, of phi J du dv for the quantities
of the signature (settings.QUANTITIES): represented area A = int J, valid area (regular
points), int |K| J, int max(K,0) J, int max(-K,0) J over the valid points, and the four
curvature-class areas of eq:curvature_classes.

The domain is cut into boundary-fitted patches mapped from the unit square
(patches: strips lo(u) <= v <= hi(u) between breakpoints, knot lines and the
trim curves' crossings of the knot lines), on which the integrands are smooth, so that
Gauss-Legendre converges fast on the exact trimmed region. One concept a module:

- settings: the quantities and the constants of every step;
- result: QuadratureResult, the integrals with their evidence;
- cells: the quadtree's cells, their nodes and the field at them;
- driver: the refinement (Integration: one loop over the quadtree levels, each level the
  named steps accept own, evaluate children, tree candidates, line candidates, accept) and
  integrate();
- lines: mixed cells integrated on lines (interpolants, exact integrals on them, Gauss-Kronrod
  in sigma), functions of a LineSetting and the MixedCells;
- crossings: the field along lines and where the level curves cross them;
- cuts: where lines are cut in sigma (edge crossings, tangencies, corners of the flat
  region, islands);
- pieces: what lines and cuts share (LineSetting, MixedCells, Pieces and their bookkeeping);
- fixed_rule: fixed tensor rules on the patches (independent checks) and patch groups;
- patches: the boundary-fitted patches of a domain and their maps from the unit square;
- gauss_rules, cell_interpolant, roots: Gauss-Legendre and Gauss-Kronrod rules, tensor
  Legendre interpolants over mixed cells, vectorised bracketed root finding.

Self-contained: imports only core and itself (a domain is anything with the attributes of
patches.DOMAIN_ATTRIBUTES, in practice geometry.trimmed_domain.TrimmedDomain).
"""
from .driver import integrate
from .cells import NodePrefetch, cell_nodes, tensor_cells, values_at_nodes
from .fixed_rule import patch_area, patch_groups, patch_rule
from .result import QuadratureResult
from .settings import GROUP_MIN_PATCHES, GROUPS, MIN_INITIAL_CELLS, NQ, QUANTITIES

__all__ = ["integrate", "NodePrefetch", "cell_nodes", "tensor_cells", "values_at_nodes", "patch_area",
           "patch_groups", "patch_rule", "QuadratureResult", "GROUP_MIN_PATCHES", "GROUPS",
           "MIN_INITIAL_CELLS", "NQ", "QUANTITIES"]
