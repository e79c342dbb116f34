"""The work and error budgets of a BRep assessment: the quadrature settings and protocols,
each face's share of the field points, the faces refined again where the shape's error sits,
and whether a face's two integrations agree within their estimates."""
import math
from dataclasses import asdict, dataclass, replace

from ...core.errors import InputError
from ..cubature import QUANTITIES
from ..cubature.settings import K_INTEGRALS
from .metric_rules import global_tolerance

PROTOCOLS = ("budget", "paper")


@dataclass(frozen=True)
class QuadratureOptions:
    """The quadrature settings of a BRep assessment, with their defaults (the one place they
    are set). protocol "budget": every face refined by its error estimates down to
    depth_limit levels, within a share of point_budget field points (its area share, at
    least FACE_POINT_FLOOR), the tolerances held by the shape's totals (metric_validity);
    "paper": the paper's campaign (section 5.2), each face on its own to max_depth,
    rechecked at max_depth + 1. order: Gauss-Legendre points per direction; rtol: relative
    tolerance of the shape's totals; audit: the nested-neighbourhood audit at degenerate
    points (singular)."""

    order: int = 5
    rtol: float = 1e-4
    max_depth: int = 5
    protocol: str = "budget"
    depth_limit: int = 30
    point_budget: int = 8_000_000
    audit: bool = True

    @property
    def paper(self):
        """Whether this is the paper's protocol (each face to max_depth, rechecked deeper)."""
        return self.protocol == "paper"

    @property
    def recheck_depth(self):
        """The depth of the paper protocol's recheck (None under the budget protocol)."""
        return self.max_depth + 1 if self.paper else None

    def record(self):
        """The settings as the assessment's options record (a dict, in field order)."""
        return asdict(self)


#: The defaults of the quadrature settings.
DEFAULT_QUADRATURE = QuadratureOptions()
#: Smallest point budget of a face (slivers and small fillets get at least this many points).
FACE_POINT_FLOOR = 100_000
#: A face's point budget is the shape's times a power of 2^(1/BUDGET_STEPS) (its share rounded
#: down to one): a small change of the shares (a face added, a patch split elsewhere) leaves the other faces' budgets, and so their
#: results and their keys in the store (brep.face_keys), as they were.
BUDGET_STEPS = 4
#: Rounds of refinement of the faces that carry the shape's excess error (faces_to_refine),
#: each with BUDGET_GROWTH times the points (or their error's share of the points left).
BUDGET_ROUNDS = 2
BUDGET_GROWTH = 4
#: A face integrated again disagrees with its earlier integration when their values differ by
#: more than this multiple of their summed error estimates: the estimates are not to be trusted.
DISAGREEMENT_SAFETY = 1.0
#: The names of the K integrals (cubature.settings.K_INTEGRALS, their columns), whose errors
#: share out the points left among the faces refined again.
K_QUANTITIES = QUANTITIES[K_INTEGRALS]


def faces_to_refine(faces, rtol):
    """Indices of the faces to refine again with more points: for every quantity whose
    summed error estimate exceeds its total's tolerance (global_tolerance), the faces whose
    refinement the point budget stopped, largest error first, until the others' errors fit
    half that tolerance."""
    out = set()
    for q in QUANTITIES:
        tol = global_tolerance(faces, q, rtol)
        errs = [f.quad.errors[q] for f in faces]
        if sum(errs) <= tol:
            continue
        rest = sum(errs)
        for i in sorted(range(len(faces)), key=lambda i: -errs[i]):
            if rest <= 0.5 * tol:
                break
            if faces[i].quad.budget_spent:
                out.add(i)
            rest -= errs[i]
    return sorted(out)


def grown_budgets(faces, budgets, total, used):
    """The next point budgets of the faces refined again (their CombinedQuadratures faces,
    budgets so far): BUDGET_GROWTH times the budget, or the face's share of the points left
    of total (used so far) by its K integrals' error estimates, whichever is larger."""
    err = [sum(f.errors[q] for q in K_QUANTITIES) for f in faces]
    s = sum(err)
    share = [e / s for e in err] if s > 0 else [1.0 / len(faces)] * len(faces)
    left = max(total - used, 0)
    return [max(BUDGET_GROWTH * b, on_grid(total, left * w / total if total > 0 else 0.0))
            for b, w in zip(budgets, share)]


def on_grid(total, share):
    """The points of a share (0 to 1) of total, the share rounded down to a power of
    2^(1/BUDGET_STEPS) (an int)."""
    if not share > 0:
        return 0
    return int(total * 2.0 ** (math.floor(BUDGET_STEPS * math.log2(min(share, 1.0)) + 1e-9) / BUDGET_STEPS))


def face_point_budgets(opts, weights):
    """Point budget of each face (None: no limit, the paper's protocol): its share weights
    (n,) of opts.point_budget (QuadratureOptions) on_grid, at least FACE_POINT_FLOOR."""
    if opts.paper or opts.point_budget is None:
        return [None] * len(weights)
    total = int(opts.point_budget)
    return [max(min(FACE_POINT_FLOOR, total), on_grid(total, w)) for w in weights]


def quadrature_options(order=None, rtol=None, max_depth=None, protocol=None, depth_limit=None,
                       point_budget=None, audit=None):
    """QuadratureOptions with the given settings (None: the default); InputError on a value
    out of range."""
    given = (("order", order), ("rtol", rtol), ("max_depth", max_depth), ("protocol", protocol),
             ("depth_limit", depth_limit), ("point_budget", point_budget), ("audit", audit))
    opts = replace(DEFAULT_QUADRATURE, **{k: v for k, v in given if v is not None})
    if opts.protocol not in PROTOCOLS:
        raise InputError("unknown quadrature protocol %r (known: %s)" % (opts.protocol, ", ".join(PROTOCOLS)))
    if int(opts.depth_limit) < 1 or int(opts.point_budget) < 1:
        raise InputError("depth limit and point budget must be >= 1, got %r and %r"
                         % (opts.depth_limit, opts.point_budget))
    return replace(opts, depth_limit=int(opts.depth_limit), point_budget=int(opts.point_budget),
                   audit=bool(opts.audit))


def disagreement(earlier, finer):
    """Quantities on which a face's finer integration (CombinedQuadrature) differs from its
    earlier one by more than DISAGREEMENT_SAFETY times their summed error estimates:
    dict quantity -> [earlier value, finer value]."""
    return {q: [earlier.values[q], finer.values[q]] for q in QUANTITIES
            if abs(finer.values[q] - earlier.values[q])
            > DISAGREEMENT_SAFETY * (finer.errors[q] + earlier.errors[q]) + 1e-12 * abs(finer.values[q])}
