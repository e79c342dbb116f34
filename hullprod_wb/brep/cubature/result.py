"""QuadratureResult: a face's integrals with their error estimates, tolerances, counts and
the locations the refinement left unresolved (scipy.integrate's habit: the value never
travels without its evidence); QuadratureValues: the integrals record and convergence that
every quadrature result of a face reads from its values."""
from dataclasses import dataclass
from typing import Optional

import numpy as np

from ...core.integrals import SurfaceIntegrals
from .settings import CLASS_AREAS, QUANTITIES


class QuadratureValues:
    """What every quadrature result of a face gives from its values and converged (dicts
    quantity (see QUANTITIES) -> float, bool): QuadratureResult and the combined result of a
    face's parts (face_result.CombinedQuadrature)."""

    @property
    def all_converged(self):
        return all(self.converged.values())

    @property
    def class_areas(self):
        """(4,) flat, single, elliptic, saddle areas."""
        return np.array([self.values[q] for q in QUANTITIES[CLASS_AREAS]])

    def integrals(self):
        """The values as a core SurfaceIntegrals record."""
        v = self.values
        return SurfaceIntegrals(v["A"], v["A_valid"], v["int_abs_K"], v["int_K_plus"],
                                v["int_K_minus"], self.class_areas)


@dataclass
class QuadratureResult(QuadratureValues):
    """Integrals over one face with their evidence.

    values, errors, tolerances: dict quantity (see QUANTITIES) -> float; values are the
    finite candidates, also where not converged. converged: dict quantity -> bool, error
    estimate within tolerance at depth <= max_depth. n_points: field points evaluated;
    n_field_calls; depth_reached: deepest quadtree level evaluated; n_cells: leaf cells;
    n_initial_cells: the first cells (the patches, halved up to MIN_INITIAL_CELLS);
    n_mixed_cells: cells integrated on lines. nonregular_uv (m, 2): (u, v) of sampled
    non-regular points (at most MAX_NONREGULAR; n_nonregular counts all). unconverged_cells
    (k, 4): [u_min, u_max, v_min, v_max] of cells left unresolved at the final depth.
    peak_KJ (N_PEAKS, 3): (u, v, |K| J) of the samples of largest |K| J, one per cell,
    largest first (candidate singular points). recheck: the
    integration continued one level deeper (paper section 5.2) when something did not
    converge and recheck was requested, else None. history: the global estimate of every
    quantity after each quadtree level (level 0: the patches' own Gauss sums, or those of the
    first cells where the patches were halved before (their level's estimate stands for the
    levels above it); level d: accepted cells plus the Gauss sums of the cells still
    refined), a list of dicts quantity -> float: the refinement sequence of the stability
    rule (section 5.2).
    zero_resolved: crossings of K = 0 cut the lines of mixed cells (else the bounds charged
    instead, zero_charge, within ZERO_CHARGE_SHARE of the K integrals' tolerances, are part
    of their error estimates; see lines.line_values). point_budget: the field points the
    refinement was given (None: no limit); budget_spent: the budget stopped it;
    budget_needed: for a run the budget never bound, the smallest budget under which it makes
    the same decisions and gives this result to the bit (None otherwise).
    """

    values: dict
    errors: dict
    tolerances: dict
    converged: dict
    order: int
    rtol: float
    max_depth: int
    depth_reached: int
    n_points: int
    n_field_calls: int
    n_cells: int
    n_initial_cells: int
    n_mixed_cells: int
    nonregular_uv: np.ndarray
    n_nonregular: int
    unconverged_cells: np.ndarray
    peak_KJ: np.ndarray
    seconds: float = 0.0
    recheck: Optional["QuadratureResult"] = None
    history: Optional[list] = None
    zero_resolved: bool = False
    zero_charge: float = 0.0
    point_budget: Optional[int] = None
    budget_spent: bool = False
    budget_needed: Optional[int] = None
    deepest_cells: Optional[np.ndarray] = None

    def to_dict(self):
        """Plain data (lists for the location arrays)."""
        out = {k: getattr(self, k) for k in ("values", "errors", "tolerances", "converged", "order",
                                             "rtol", "max_depth", "depth_reached", "n_points",
                                             "n_field_calls", "n_cells", "n_initial_cells",
                                             "n_mixed_cells", "n_nonregular", "seconds",
                                             "zero_resolved", "zero_charge", "point_budget",
                                             "budget_spent", "budget_needed")}
        out["nonregular_uv"] = self.nonregular_uv.tolist()
        out["unconverged_cells"] = self.unconverged_cells.tolist()
        out["peak_KJ"] = self.peak_KJ.tolist()
        out["deepest_cells"] = None if self.deepest_cells is None else self.deepest_cells.tolist()
        out["history"] = self.history
        out["recheck"] = None if self.recheck is None else self.recheck.to_dict()
        return out
