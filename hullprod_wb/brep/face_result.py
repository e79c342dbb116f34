"""What the assessment of one BRep face holds: the quadrature of its parts combined
(CombinedQuadrature: the face with its singular neighbourhoods excluded, and each
neighbourhood through its graded map) and the face's assessment (FaceAssessment), which
leaves a worker process as plain data."""
from dataclasses import dataclass
from dataclasses import field as dc_field
from typing import Optional

from .cubature import QUANTITIES
from .cubature.result import QuadratureValues


#: A neighbourhood quadrant or pinch triangle of a face is integrated within 1/PIECE_BUDGET_SHARE
#: of the face's point budget (a patch group within its share of the groups).
PIECE_BUDGET_SHARE = 2


def part_budget(point_budget, divisor):
    """A part's point budget: the face's point_budget split divisor ways, at least 1 (None:
    no limit)."""
    return None if point_budget is None else max(1, int(point_budget) // int(divisor))


def final_result(q):
    """The deepest result of a quadrature (the depth-6 recheck when there was one)."""
    return q.recheck if q.recheck is not None else q


class CombinedQuadrature(QuadratureValues):
    """Quadrature of a face made of parts: the face with its singular neighbourhoods
    excluded (n_main parts: its patch groups), and each neighbourhood quadrant through its
    graded map. Sums values, errors and counts. A quantity is converged when every main part
    converged (at its deepest check) and the summed error estimates of all parts are within
    their summed tolerances."""

    def __init__(self, parts, n_main=1):
        self.parts = parts
        self.n_main = int(n_main)
        finals = [final_result(p) for p in parts]
        self.values = {k: float(sum(f.values[k] for f in finals)) for k in QUANTITIES}
        self.errors = {k: float(sum(f.errors[k] for f in finals)) for k in QUANTITIES}
        main = finals[:self.n_main]
        self.converged = {k: bool(all(m.converged[k] for m in main) and
                                  self.errors[k] <= sum(f.tolerances[k] for f in finals))
                          for k in QUANTITIES}
        self.depth_reached = max(f.depth_reached for f in finals)
        self.n_points = int(sum(p.n_points + (p.recheck.n_points if p.recheck is not None else 0)
                                for p in parts))
        self.rechecked = any(p.recheck is not None for p in parts)
        self.budget_spent = any(getattr(f, "budget_spent", False) for f in finals)
        # refinement sequence: the parts' level estimates summed level by level (a part
        # that stopped earlier keeps its last estimate)
        hist = [(f.history or [f.values]) for f in finals]
        self.history = [{k: float(sum(h[min(d, len(h) - 1)][k] for h in hist)) for k in QUANTITIES}
                        for d in range(max(len(h) for h in hist))]

    def divisors(self):
        """How many ways the face's point budget is split for each part (part_budget)."""
        return [self.n_main] * self.n_main + [PIECE_BUDGET_SHARE] * (len(self.parts) - self.n_main)

    def budget_needed(self):
        """The smallest point budget of the face under which every part makes the same
        decisions (each part's budget_needed, cubature.driver), None when the budget bound a
        part or there was none."""
        need = 0
        for p, d in zip(self.parts, self.divisors()):
            n = getattr(p, "budget_needed", None)
            if n is None or p.recheck is not None:
                return None
            need = max(need, d * n)  # point_budget // d >= n exactly when point_budget >= d n
        return need

    def with_budget(self, point_budget):
        """Self with the parts' point budgets those of a face given point_budget."""
        for p, d in zip(self.parts, self.divisors()):
            p.point_budget = part_budget(point_budget, d)
        return self

    def to_dict(self):
        return {"values": self.values, "errors": self.errors, "converged": self.converged,
                "depth_reached": self.depth_reached, "n_points": self.n_points, "rechecked": self.rechecked,
                "budget_spent": self.budget_spent,
                "patch_groups": self.n_main, "parts": [p.to_dict() for p in self.parts]}


@dataclass
class DomainSummary:
    """What the records say of a face's trimmed domain (kept when the domain is dropped)."""

    is_rectangle: bool
    fallback: Optional[str] = None
    repairs: list = dc_field(default_factory=list)


class FaceAssessment:
    """Everything computed for one face: its number, field and trimmed domain (OpenCascade
    objects until detach()), knot and neighbourhood lines, degenerate set, neighbourhood
    quadrants, quadrature (quad: a CombinedQuadrature), audits, and the cross-checks (None
    until cross_checks.face_cross_checks)."""

    def __init__(self, number, ff, domain, breaks, degenerate, quadrants, quad, audits):
        self.number, self.ff, self.domain = number, ff, domain
        self.u_breaks, self.v_breaks = breaks  # knot lines and neighbourhood box lines
        self.degenerate, self.quadrants, self.quad, self.audits = degenerate, quadrants, quad, audits
        self.surface_type = ff.surface_type
        self.kind = ff.kind
        self.cross_check = None
        self.disagreement = {}  # quantity -> [earlier, finer] where a second integration disagreed
        # the smallest point budget giving this same assessment to the bit, None when the
        # budget bound it (assess_face)
        self.budget_needed = None

    def renumbered(self, number):
        """Self as face number (a result from the store, made for the same face under another
        number). Returns self."""
        self.number = number
        if isinstance(self.cross_check, dict) and "face" in self.cross_check:
            self.cross_check["face"] = number
        return self

    def fits(self, point_budget):
        """Whether a face given point_budget is assessed as this one was, to the bit: the
        budget bound no integration of it and point_budget is at least budget_needed."""
        return self.budget_needed is not None and point_budget is not None and point_budget >= self.budget_needed

    def with_budget(self, point_budget):
        """Self as assessed with point_budget (fits): the parts' budgets say so. Returns self."""
        self.quad.with_budget(point_budget)
        return self

    def detach(self):
        """Drop the face field and the trimmed domain (OpenCascade objects), keeping what the
        records need, so that the assessment can leave a worker process. Returns self."""
        d = self.domain
        self.domain = DomainSummary(bool(d.is_rectangle), d.fallback, list(d.repairs))
        self.ff = None
        return self
