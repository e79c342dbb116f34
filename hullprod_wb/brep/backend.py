"""Native-BRep realization of the signature (paper section 4.1).

Exact derivatives of each face (batched NURBS or closed form), H and K from the
fundamental forms (eq:brephk), adaptive boundary-fitted Gauss-Legendre cubature over the
trimmed domain (eq:brep_surface_integral), graded refinement and a nested-neighbourhood
audit at degenerate points, and per-metric validity (section 4.3).
"""
import functools
import time
from dataclasses import dataclass
from dataclasses import field as dc_field
from typing import Optional

import numpy as np

from ..core.constants import CLASS_METRICS, CLASS_NAMES, DEFAULT_HF, DEFAULT_KF, METRICS
from ..core.errors import InputError
from ..core.integrals import SurfaceIntegrals
from ..core.progress import null_progress
from ..core.reference_length import resolve_reference_length
from ..core.result import Assessment
from ..core.signature import signature_values
from ..core.thresholds import Thresholds
from ..core.validity import MetricValidity, Status
from ..freecad_env import set_reported_versions
from . import plain_records, singular
from .display import (DISPLAY_DEFLECTION, SAMPLE_DEFLECTION, display_fields, sample_faces,
                      tessellation_samples)
from .face_field import FaceField
from .face_pool import map_faces, map_forked, resolve_jobs
from .loading import BRepInput, load_brep
from .lref_samples import read_and_start
from .left_out import EmptyDomain, LeftOutFace, evaluated_faces, left_out_face, mark_left_out
from .provenance import occ_face_area, shape_boxes, shape_provenance
from .patches import Patches
from .plain_records import ReadInChild, cross_check_params, occ_reference, patch_count
from .recorded_shape import FaceRecord, RecordedShape
from .cubature import GROUPS, QUANTITIES, NodePrefetch, integrate, patch_area, patch_groups
from .trimmed_domain import TrimmedDomain

#: Quadrature settings; all are options. protocol "budget": every face refined by its error
#: estimates down to depth_limit levels, within a share of point_budget field points (its
#: area share, at least FACE_POINT_FLOOR), the tolerances held by the shape's totals
#: (metric_validity); "paper": the paper's campaign (section 5.2), each face on its own to
#: max_depth, rechecked at max_depth + 1.
DEFAULT_QUADRATURE = {"order": 5, "rtol": 1e-4, "max_depth": 5, "protocol": "budget", "depth_limit": 30,
                      "point_budget": 8_000_000}
PROTOCOLS = ("budget", "paper")
#: Smallest point budget of a face (slivers and small fillets get at least this many points).
FACE_POINT_FLOOR = 100_000
#: Stability rule for I_D over the global refinement sequence: last and prior relative change.
ID_STABILITY = (0.02, 0.03)
#: A face whose share of int|K| exceeds this many times its share of area (and 1 %) is named.
CONCENTRATION_RATIO = 20.0
#: Numerator and denominator quantities of each metric.
METRIC_QUANTITIES = {"I_D": ("int_abs_K", "A_valid"), "I_D_plus": ("int_K_plus", "A_valid"),
                     "I_D_minus": ("int_K_minus", "A_valid"),
                     "a_flat": ("A_flat", "A_classified"), "a_single": ("A_single", "A_classified"),
                     "a_elliptic": ("A_elliptic", "A_classified"), "a_saddle": ("A_saddle", "A_classified")}
#: Tree depth and class-line halvings of a graded neighbourhood quadrant.
QUADRANT_MAX_DEPTH = 5
QUADRANT_CLASS_DEPTH = 1
#: Relative width of the threshold bands recorded with the class fractions (threshold_band).
THRESHOLD_BAND = 0.1
#: Rounds of refinement of the faces that carry the shape's excess error (faces_to_refine),
#: each with BUDGET_GROWTH times the points (or their error's share of the points left).
BUDGET_ROUNDS = 2
BUDGET_GROWTH = 4
#: A face integrated again disagrees with its earlier integration when their values differ by
#: more than this multiple of their summed error estimates: the estimates are not to be trusted.
DISAGREEMENT_SAFETY = 1.0
#: ... and a disagreement qualifies a metric when it exceeds this share of its total's tolerance.
DISAGREEMENT_SHARE = 0.1
#: Rounds of grading at knot-grid nodes where a face's refinement stalled.
STALL_ROUNDS = 2
#: Points per face for the pointwise cross-check against OpenCascade.
CROSS_CHECK_POINTS = plain_records.CROSS_CHECK_POINTS


def _final(q):
    """The deepest result of a quadrature (the depth-6 recheck when there was one)."""
    return q.recheck if q.recheck is not None else q


def cross_check_occ(ff, reference=None, n=CROSS_CHECK_POINTS):
    """Max relative differences of S_u, S_v, H, K against OpenCascade at interior points of
    the face's parameter range (plain_records.cross_check_params); reference: OpenCascade's
    values there (plain_records.occ_reference), computed from ff.face when not given."""
    if reference is None:
        reference = occ_reference(ff.face, n)
    u, v = (np.array(x) for x in cross_check_params(ff.evaluator.parameter_range, n))
    ours = ff(u, v)
    der = ff.evaluator.derivatives(u, v)
    worst = {"Su": 0.0, "Sv": 0.0, "H": 0.0, "K": 0.0}
    checked = 0
    for i in range(n):
        if reference[i] is None:  # undefined curvature at a degenerate point: nothing to compare
            continue
        du, dv, Kocc, Hocc = reference[i]
        Hocc = ff.sign * Hocc
        checked += 1
        for name, a, b in (("Su", der[1][i], du), ("Sv", der[2][i], dv)):
            b = np.array(b)
            worst[name] = max(worst[name], float(np.linalg.norm(a - b) / max(np.linalg.norm(b), 1e-300)))
        for name, a, b in (("H", ours["H"][i], Hocc), ("K", ours["K"][i], Kocc)):
            scale = max(abs(b), abs(ours["k1"][i] * ours["k2"][i]) if name == "K" else abs(b), 1e-300)
            scale = max(scale, ours["k1"][i] ** 2 if name == "K" else abs(ours["k1"][i]), 1e-300)
            worst[name] = max(worst[name], float(abs(a - b) / scale))
    worst["points"] = checked
    return worst


def area_rule(ff, domain, u_breaks, v_breaks):
    """Represented area by the fixed tensor Gauss-Legendre rule of order 8 on every
    boundary-fitted patch (cubature.patch_area), an estimate independent of the adaptive
    cubature, and the embedded-rule bound on its own error: (area, bound). Only J is
    evaluated (first derivatives: FaceField.area_element)."""
    return patch_area(domain, ff.area_element, 8, u_breaks, v_breaks, ff.area_element_grid)


def area_cross_check(rule, area):
    """The record comparing the adaptive cubature's area with area_rule's (area, bound)."""
    ref, bound = rule
    return {"method": "tensor Gauss-Legendre order 8 on the boundary-fitted patches",
            "area": ref, "check_error_bound": bound,
            "relative_difference": abs(area - ref) / ref if ref else None}


class CombinedQuadrature:
    """Quadrature of a face made of parts: the face with its singular neighbourhoods
    excluded (n_main parts: its patch groups), and each neighbourhood quadrant through its
    graded map. Sums values, errors and counts. A quantity is converged when every main part
    converged (at its deepest check) and the summed error estimates of all parts are within
    their summed tolerances."""

    def __init__(self, parts, n_main=1):
        self.parts = parts
        self.n_main = int(n_main)
        finals = [_final(p) for p in parts]
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

    @property
    def all_converged(self):
        return all(self.converged.values())

    def integrals(self):
        v = self.values
        return SurfaceIntegrals(v["A"], v["A_valid"], v["int_abs_K"], v["int_K_plus"], v["int_K_minus"],
                                np.array([v[q] for q in QUANTITIES[5:]]))

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
    quadrants, quadrature, audits, and the cross-checks (None until face_cross_checks)."""

    def __init__(self, number, ff, domain, breaks, degenerate, quadrants, quad, audits):
        self.number, self.ff, self.domain = number, ff, domain
        self.u_breaks, self.v_breaks = breaks  # knot lines and neighbourhood box lines
        self.degenerate, self.quadrants, self.quad, self.audits = degenerate, quadrants, quad, audits
        self.surface_type = ff.surface_type
        self.kind = ff.kind
        self.cross_check = None
        self.disagreement = {}  # quantity -> [earlier, finer] where a second integration disagreed

    @property
    def result(self):
        return self.quad

    def detach(self):
        """Drop the face field and the trimmed domain (OpenCascade objects), keeping what the
        records need, so that the assessment can leave a worker process. Returns self."""
        d = self.domain
        self.domain = DomainSummary(bool(d.is_rectangle), getattr(d, "fallback", None),
                                    list(getattr(d, "repairs", None) or []))
        self.ff = None
        return self


def face_cross_checks(f, rule=None, seconds=0.0, reference=None):
    """Cross-checks of one assessed face (needs its field and domain): derivatives and H, K
    against OpenCascade at interior points (reference: OpenCascade's values there, when
    already known), and the independent fixed-rule area (rule: its area_rule when already
    computed, in seconds)."""
    t = time.perf_counter()
    rec = {"face": f.number, "occ_pointwise_max_relative": cross_check_occ(f.ff, reference)}
    if rule is None:
        rule = area_rule(f.ff, f.domain, f.u_breaks, f.v_breaks)
    rec["area"] = area_cross_check(rule, f.result.values["A"])
    rec["seconds"] = seconds + time.perf_counter() - t
    return rec


#: Deflection of the 3-D edge polygons of a fallback domain, relative to the face's size.
POLYGON_DEFLECTION = 1e-6


def polygon_domain(face):
    """Fallback trimmed domain when the face's p-curves do not form closed loops: each wire
    discretised in 3-D (deflection POLYGON_DEFLECTION of the face's size), its points
    projected into the face's parameter space, joined by straight lines (closed by
    construction). Exact for straight trims of planes; otherwise an approximation that the
    validity record names."""
    from .trimmed_domain import NurbsCurve2D
    size = max(face.BoundBox.DiagonalLength, 1e-300)
    surf = face.Surface
    curves = []
    for wire in face.Wires:
        pts = wire.discretize(Deflection=POLYGON_DEFLECTION * size)
        uv = np.array([surf.parameter(p) for p in pts], dtype=float)
        if len(uv) > 1 and np.allclose(uv[0], uv[-1]):
            uv = uv[:-1]
        for i in range(len(uv)):
            a, b = uv[i], uv[(i + 1) % len(uv)]
            if np.any(a != b):
                curves.append(NurbsCurve2D.line(a, b))
    domain = TrimmedDomain.from_curves(curves)
    return domain


class _NeedsPartFace(Exception):
    """A recorded face whose trimmed domain needs the Part face (FaceSetup(part_face=False))."""


class FaceSetup:
    """What a face's integration needs before the class thresholds are known: its field and
    trimmed domain, knot lines, degenerate set and neighbourhood quadrants, the knot and
    box lines of its patches (gu, gv), the field with the neighbourhoods excluded, and the
    independent area rule once computed (area_rule, with its seconds). part_face=False: a
    recorded face whose domain needs the Part face raises _NeedsPartFace instead of reading
    the file here."""

    def __init__(self, face, area_check=False, part_face=True):
        self.recorded = isinstance(face, FaceRecord)
        ff = face.field() if self.recorded else None
        domain = face.domain(ff.evaluator) if self.recorded else None
        if domain is not None:
            domain.fallback = None
        else:
            if self.recorded:  # a domain that needs OpenCascade itself: the face, read here
                if not part_face:
                    raise _NeedsPartFace()
                face = face.part_face()
                self.recorded = False
            ff = FaceField(face)
            try:
                domain = TrimmedDomain.from_face(face)
                domain.fallback = None
            except InputError as exc:
                domain = polygon_domain(face)
                domain.fallback = " ".join(str(exc).split())
        self.ff, self.domain = ff, domain
        if not (domain.u_range[1] > domain.u_range[0] and domain.v_range[1] > domain.v_range[0]):
            raise EmptyDomain("u in [%r, %r], v in [%r, %r]" % (*domain.u_range, *domain.v_range))
        u_breaks, v_breaks = ff.evaluator.continuity_breaks(urange=domain.u_range, vrange=domain.v_range)
        self.u_breaks, self.v_breaks = u_breaks, v_breaks
        self.deg = singular.find_degenerate(ff, domain, u_breaks, v_breaks)
        self._neighbourhoods()
        self.check = {}
        if area_check:
            self.area_check()

    def _neighbourhoods(self):
        """Quadrants of the degenerate set's graded points, the patches' lines gu, gv and the
        field with the neighbourhoods excluded."""
        ff, domain, u_breaks, v_breaks = self.ff, self.domain, self.u_breaks, self.v_breaks
        self.quads = singular.neighbourhood_quadrants(self.deg, domain, u_breaks, v_breaks) if self.deg else []
        self.gu, self.gv = u_breaks, v_breaks
        self.main_field = ff
        if self.quads:
            qu, qv = singular.quadrant_breaks(self.quads)
            self.gu = np.unique(np.concatenate([np.asarray(u_breaks, float), qu]))
            self.gv = np.unique(np.concatenate([np.asarray(v_breaks, float), qv]))
            self.main_field = singular.ExcludedBoxesField(ff, [q.box for q in self.quads])
        self.prefetch = None
        self.__dict__.pop("patches", None)

    def add_stalled_points(self, points):
        """Grade and audit the knot-grid nodes where a refinement stalled
        (singular.points_from_refinement) from now on. Returns whether any point got a
        neighbourhood inside the domain."""
        before = len(self.quads)
        self.deg.stalled.extend(points)
        self._neighbourhoods()
        return len(self.quads) > before

    @classmethod
    def here(cls, face, area_check=False):
        """FaceSetup(face) when its records describe its trimmed domain (or it is a Part face),
        else None: a face that needs OpenCascade is set up in the process that integrates it."""
        try:
            return cls(face, area_check, part_face=False)
        except _NeedsPartFace:
            return None

    def prefetch_until(self, done, order, groups, max_depth):
        """The field at the nodes of the first two quadtree levels of the face's integration,
        of each of its patch groups when groups (cubature.NodePrefetch: the field alone, no
        thresholds), level by level until done() (L_ref has arrived); assess_face uses them."""
        if done():
            return
        ranges = patch_groups(self.patches.size) if groups else [None]
        self.prefetch = [NodePrefetch(self.domain, self.main_field, order, self.gu, self.gv, r, self.patches,
                                      max_depth) for r in ranges]
        for level in range(2):  # the groups' first cells, then their children
            for p in self.prefetch:
                while len(p.values) <= level:
                    if done():
                        return
                    p.step()

    @functools.cached_property
    def patches(self):
        """The boundary-fitted patches of the face's integration (Patches.of domain, gu, gv)."""
        return Patches.of(self.domain, self.gu, self.gv)

    def area_check(self):
        """area_rule of the face (independent of the adaptive cubature), once."""
        if "rule" not in self.check:
            t = time.perf_counter()
            self.check["rule"] = area_rule(self.ff, self.domain, self.gu, self.gv)
            self.check["seconds"] = time.perf_counter() - t


def set_up_or_none(face, area_check, here=False):
    """FaceSetup(face, area_check) (FaceSetup.here when here), or None when the set-up
    raises: the face is then set up again where it is integrated, and left out there
    (left_out.left_out_face) when it raises again."""
    try:
        return FaceSetup.here(face, area_check) if here else FaceSetup(face, area_check=area_check)
    except Exception:  # recorded by the face's own assessment
        return None


def set_up_until(done, faces, cost, area_check):
    """FaceSetup.here of the faces, smallest cost first, each with its area rule when
    area_check, until done() (None: none is set up): a list with None where a face was not
    set up."""
    setups = [None] * len(faces)
    if done is None:
        return setups
    for i in sorted(range(len(faces)), key=lambda i: cost[i]):
        if done():
            break
        setups[i] = set_up_or_none(faces[i], False, here=True)
        if area_check and setups[i] is not None and not done():
            setups[i].area_check()
    return setups


def assess_face(number, face, thresholds, lref, opts, progress=null_progress, groups=False, group_jobs=1,
                cross_checks=True, setup=None, point_budget=None):
    """Integrate one face; neighbourhoods of degenerate points and hot spots are integrated
    separately through a graded map (singular.GradedQuadrantField), then audited. With
    groups, a face of many patches is integrated in patch groups (cubature.patch_groups),
    in group_jobs processes (face_pool.map_forked; the values do not depend on it), and
    this process computes the area cross-check while it waits for the others (unless the
    setup has it). cross_checks: attach face_cross_checks. face: a Part.Face, or a
    recorded_shape.FaceRecord (the same field and domain from its records, and OpenCascade's
    cross-check values). setup: its FaceSetup when already made."""
    s = setup or FaceSetup(face)
    quad = _integrate_face(s, thresholds, opts, progress, groups, group_jobs, cross_checks, point_budget)
    for _ in range(STALL_ROUNDS if opts.get("protocol") != "paper" and opts.get("audit", True) else 0):
        # a refinement that stalled at a knot-grid node: graded there and audited (VALID* or
        # SINGULAR), instead of ever smaller cells (paper section 4.3)
        pts = singular.points_from_refinement([_final(p) for p in quad.parts[:quad.n_main]], s.domain,
                                              s.u_breaks, s.v_breaks, s.deg.graded_points)
        if not pts or not s.add_stalled_points(pts):
            break
        quad = _integrate_face(s, thresholds, opts, progress, groups, group_jobs, False, point_budget)
    ff, domain, deg, quads, gu, gv = s.ff, s.domain, s.deg, s.quads, s.gu, s.gv
    audits = []
    if deg and opts.get("audit", True):
        totals = dict(quad.values)
        for p in deg.audited_points:
            audits.append(singular.audit_point(ff, p, quads, totals, lref, thresholds.tau_H,
                                               thresholds.tau_K, order=opts["order"]))
        for side in deg.sides:
            audits.append(singular.probe_side(ff, domain, side, s.u_breaks, s.v_breaks))
    f = FaceAssessment(number, ff, domain, (gu, gv), deg, quads, quad, audits)
    if cross_checks:
        f.cross_check = face_cross_checks(f, s.check.get("rule"), s.check.get("seconds", 0.0),
                                          reference=face.occ_reference if s.recorded else None)
    return f


def _integrate_face(s, thresholds, opts, progress, groups, group_jobs, area_check, point_budget):
    """CombinedQuadrature of a set-up face (FaceSetup s): its patch groups (in group_jobs
    processes when groups), then each neighbourhood quadrant through its graded map. With
    the budget protocol (opts["protocol"] != "paper") the groups refine by their error down
    to opts["depth_limit"] within point_budget points (split between the groups); with the
    paper's, to max_depth with a recheck one level deeper (section 5.2)."""
    ff, domain, quads, gu, gv, main_field = s.ff, s.domain, s.quads, s.gu, s.gv, s.main_field
    kw = dict(order=opts["order"], rtol=opts["rtol"], max_depth=opts["max_depth"], recheck=True)
    groups = patch_groups(s.patches.size) if groups else [None]
    mkw = dict(kw)
    if opts.get("protocol") != "paper":
        mkw.update(depth_limit=opts["depth_limit"],
                   point_budget=None if point_budget is None else max(1, int(point_budget) // len(groups)))
    prefetch = s.prefetch if s.prefetch is not None and len(s.prefetch) == len(groups) else [None] * len(groups)

    def main_part(g):  # progress from the group integrated in this process
        return integrate(domain, main_field, thresholds.tau_H, thresholds.tau_K, u_breaks=gu, v_breaks=gv,
                         progress=progress if g == 0 else None, patch_range=groups[g], prefetch=prefetch[g], **mkw)

    # the area rule is independent of the adaptive cubature: while other groups finish
    parts = map_forked(main_part, len(groups), group_jobs, while_waiting=s.area_check if area_check else None)
    n_main = len(parts)
    unit = TrimmedDomain.rectangle(0.0, 1.0, 0.0, 1.0) if quads else None
    # Each neighbourhood quadrant may use up to a 1/(2 n) share of the face's tolerance; the
    # graded map makes its integrand smooth, so a shallow tree resolves it.
    main_values = {k: sum(_final(p).values[k] for p in parts) for k in QUANTITIES}
    share = {k: abs(v) / (2.0 * max(len(quads), 1)) for k, v in main_values.items()}
    qkw = dict(kw, max_depth=min(opts["max_depth"], QUADRANT_MAX_DEPTH), class_max_depth=QUADRANT_CLASS_DEPTH)
    if opts.get("protocol") != "paper":  # refined by the error too, within a share of the face's points
        qkw.update(depth_limit=opts["depth_limit"],
                   point_budget=None if point_budget is None else max(1, int(point_budget) // 2))
    for q in quads:
        parts.append(integrate(unit, singular.GradedQuadrantField(ff, q), thresholds.tau_H, thresholds.tau_K,
                               reference=share, **qkw))

    return CombinedQuadrature(parts, n_main)


def _global_tolerance(faces, quantity, rtol):
    """Tolerance of a quantity's total over the faces: rtol max(|total|, 1e-2 A) for areas,
    rtol |total| for the K integrals."""
    total = sum(f.quad.values[quantity] for f in faces)
    scale = max(abs(total), 1e-2 * sum(f.quad.values["A"] for f in faces)
                if quantity.startswith("A") else abs(total))
    return rtol * scale


def _global_converged(faces, quantity, rtol):
    """Converged on every face, or the summed error estimate within the total's tolerance
    (_global_tolerance): one error budget for the whole shape."""
    if all(f.quad.converged[quantity] for f in faces):
        return True
    return sum(f.quad.errors[quantity] for f in faces) <= _global_tolerance(faces, quantity, rtol)


def _quantity_total(faces, q):
    if q == "A_classified":
        return sum(f.quad.values[c] for f in faces for c in ("A_flat", "A_single", "A_elliptic", "A_saddle"))
    return sum(f.quad.values[q] for f in faces)


def face_records(faces, integrals, lref, tau_H, tau_K):
    """Per-face table: area, shares, face-level signature, status, surface type."""
    A_tot = integrals.valid_area
    K_tot = integrals.int_abs_K
    rows = []
    for f in faces:
        r = f.result
        ig = r.integrals()
        vals = signature_values(ig, lref)
        verdicts = [a["verdict"] for a in f.audits]
        if not r.all_converged:
            status = Status.UNCONVERGED
        elif "divergent" in verdicts:
            status = Status.SINGULAR
        elif "inconclusive" in verdicts or "not_audited" in verdicts:
            status = Status.CAUTION
        elif "convergent" in verdicts:
            status = Status.VALID_STAR
        else:
            status = Status.VALID
        rows.append({
            "face": f.number, "surface_type": f.surface_type, "evaluation": f.kind,
            "area": r.values["A"], "valid_area": r.values["A_valid"],
            "area_share": r.values["A_valid"] / A_tot if A_tot > 0 else None,
            "K_share": r.values["int_abs_K"] / K_tot if K_tot > 0 else None,
            "I_D": vals["I_D"], "I_D_plus": vals["I_D_plus"], "I_D_minus": vals["I_D_minus"],
            "a_C": {n: vals[m] for n, m in zip(CLASS_NAMES, CLASS_METRICS)},
            "status": status.value, "converged": bool(r.all_converged),
            "refinements_disagree": dict(getattr(f, "disagreement", None) or {}),
            "points": int(f.quad.n_points),
            "depth_reached": int(r.depth_reached), "trimmed": not f.domain.is_rectangle,
            "domain": ("polygon from the 3-D edges (%s)" % f.domain.fallback) if f.domain.fallback
            else "exact p-curves" + (" (repaired: %s)" % "; ".join(f.domain.repairs)
                                     if getattr(f.domain, "repairs", None) else ""),
            "repairs": list(getattr(f.domain, "repairs", [])),
            "degenerate": f.degenerate.to_dict(),
        })
    return rows


def concentrated_faces(rows):
    """Faces whose share of int|K| is far beyond their share of area (slivers, collapsed patches)."""
    out = []
    for r in rows:
        a, k = r["area_share"], r["K_share"]
        if a is not None and k is not None and k > 0.01 and (a <= 0 or k / a > CONCENTRATION_RATIO):
            out.append({"face": r["face"], "area": r["area"], "area_share": a, "K_share": k})
    return out


def metric_validity(faces, integrals, values, opts, history):
    """Validity record of each signature metric (paper section 4.3)."""
    rtol = opts["rtol"]
    audits = [a for f in faces for a in f.audits]
    verdicts = [a["verdict"] for a in audits]
    deg_count = sum(len(f.degenerate.points) + len(f.degenerate.sides) for f in faces)
    fallback = [f.number for f in faces if getattr(f.domain, "fallback", None)]
    # exact repairs of trim loops (gaps within a vertex's tolerance): no CAUTION, but evidence
    repaired = [f.number for f in faces if getattr(f.domain, "repairs", None)]
    rep, valid = integrals.represented_area, integrals.valid_area
    out = {}
    for m in METRICS:
        num, den = METRIC_QUANTITIES[m]
        conv = _global_converged(faces, num, rtol) and (
            den == "A_classified" or _global_converged(faces, den, rtol))
        if den == "A_classified":
            conv = conv and all(_global_converged(faces, c, rtol) for c in ("A_flat", "A_single", "A_elliptic", "A_saddle"))
        evidence = {"error_estimate": sum(f.result.errors.get(num, 0.0) for f in faces),
                    "numerator": _quantity_total(faces, num), "denominator": _quantity_total(faces, den),
                    "points": int(sum(f.quad.n_points for f in faces))}
        evidence["tolerance"] = _global_tolerance(faces, num, rtol)
        if opts.get("protocol") == "paper":
            evidence.update({"depth_limit": opts["max_depth"], "recheck_depth": opts["max_depth"] + 1,
                             "rechecked_faces": [f.number for f in faces if f.quad.rechecked]})
        else:
            evidence.update({"depth_limit": opts["depth_limit"], "point_budget": opts["point_budget"],
                             "budget_spent_faces": [f.number for f in faces if f.quad.budget_spent]})
        if repaired:
            evidence["repaired_domains"] = repaired
        is_K = den == "A_valid"
        if valid <= 0:
            rec = MetricValidity(Status.NOT_EVALUATED, None, "no regular surface area to evaluate",
                                 "no_valid_area", rep, valid, evidence)
        elif not conv:
            reason = ("adaptive quadrature did not reach the tolerance %g at depth %d, nor at %d"
                      % (rtol, opts["max_depth"], opts["max_depth"] + 1) if opts.get("protocol") == "paper" else
                      "the summed error estimate %.3g exceeds the tolerance %.3g (rtol %g of the total) with the "
                      "point budget spent on face(s) %s" % (evidence["error_estimate"], evidence["tolerance"], rtol,
                                                            ",".join(map(str, evidence["budget_spent_faces"])) or "none"))
            rec = MetricValidity(Status.UNCONVERGED, values[m], reason, "quadrature_unresolved", rep, valid, evidence)
        elif is_K and "divergent" in verdicts:
            evidence["audit"] = audits
            rec = MetricValidity(Status.SINGULAR, values[m],
                                 "the |K| integral does not shrink with the neighbourhood of a singular point",
                                 "non_integrable_singularity", rep, valid, evidence)
        elif m == "I_D" and history and not _stable(history):
            evidence["refinement_sequence"] = history
            rec = MetricValidity(Status.UNCONVERGED, values[m],
                                 "I_D changed by more than 2 %/3 % over the last global refinements",
                                 "refinement_unstable", rep, valid, evidence)
        elif is_K and ("inconclusive" in verdicts or "not_audited" in verdicts):
            evidence["audit"] = audits
            rec = MetricValidity(Status.CAUTION, values[m],
                                 "degenerate points whose neighbourhood could not be shown regular or convergent",
                                 "singular_set_unresolved", rep, valid, evidence)
        elif is_K and "convergent" in verdicts:
            evidence["audit"] = audits
            pw = [a["decay_power"] for a in audits if a["verdict"] == "convergent"]
            rec = MetricValidity(Status.VALID_STAR, values[m],
                                 "convergent improper integral: |K| is unbounded at %d degenerate point(s); the "
                                 "excluded |K| integral decays like r^%.2f" % (len(pw), min(pw)),
                                 "convergent_improper", rep, valid, evidence)
        elif _disagreeing(faces, num, den, rtol):
            bad = _disagreeing(faces, num, den, rtol)
            evidence["disagreeing_refinements"] = bad
            rec = MetricValidity(Status.CAUTION, values[m],
                                 "face(s) %s: a finer integration differs from the earlier one by more than their "
                                 "error estimates, which are therefore not reliable there"
                                 % ",".join(str(b["face"]) for b in bad), "error_estimate_unreliable",
                                 rep, valid, evidence)
        elif fallback:
            evidence["approximate_domains"] = fallback
            rec = MetricValidity(Status.CAUTION, values[m],
                                 "face(s) %s: trim curves do not close; their domain is a polygon from the "
                                 "3-D edges" % ",".join(str(n) for n in fallback), "approximate_trim_domain",
                                 rep, valid, evidence)
        else:
            reason = ""
            code = "converged"
            if deg_count:
                reason = ("converged; %d degenerate parameter point(s)/side(s) with bounded curvature "
                          "(parameterisation degeneracy)" % deg_count if all(v == "regular" for v in verdicts)
                          else "converged; singular points carry zero area")
                code = "converged_degenerate_parameterisation"
                evidence["audit"] = audits
            rec = MetricValidity(Status.VALID, values[m], reason, code, rep, valid, evidence)
        if m == "I_D" and history:
            rec.evidence["refinement_sequence"] = history
        if fallback and rec.code != "approximate_trim_domain":
            rec.evidence["approximate_domains"] = fallback
            rec.reason = (rec.reason + "; " if rec.reason else "") + (
                "face(s) %s: trim curves do not close, domain from the 3-D edges" % ",".join(map(str, fallback)))
        out[m] = rec
    return out


def _disagreeing(faces, num, den, rtol):
    """Faces integrated again whose two integrations disagree on the quantities of a metric
    (numerator num, denominator den) beyond their error estimates, by more than
    DISAGREEMENT_SHARE of the total's tolerance (_global_tolerance), with both values."""
    qs = {num, den} if den != "A_classified" else {num, "A_flat", "A_single", "A_elliptic", "A_saddle"}
    tol = {q: _global_tolerance(faces, q, rtol) for q in qs}
    out = []
    for f in faces:
        d = getattr(f, "disagreement", None) or {}
        hit = {q: d[q] for q in sorted(qs) if q in d and abs(d[q][1] - d[q][0]) > DISAGREEMENT_SHARE * tol[q]}
        if hit:
            out.append({"face": f.number, "values": hit})
    return out


def _stable(history):
    """I_D stability rule (section 5.2): last and prior relative changes <= 2 % and 3 %."""
    seq = [h["I_D"] for h in history if h.get("I_D") is not None]
    if len(seq) < 3:
        return True
    c_last = abs(seq[-1] - seq[-2]) / abs(seq[-1]) if seq[-1] else 0.0
    c_prior = abs(seq[-2] - seq[-3]) / abs(seq[-2]) if seq[-2] else 0.0
    return c_last <= ID_STABILITY[0] and c_prior <= ID_STABILITY[1]


def refinement_history(faces, lref):
    """Global I_D, I_D+, I_D- after each quadtree level (summed over faces), when recorded."""
    per_face = [getattr(f.result, "history", None) for f in faces]
    if not per_face or any(h is None for h in per_face):
        return []
    depth = max(len(h) for h in per_face)
    out = []
    for d in range(depth):
        tot = {}
        for h in per_face:
            vals = h[min(d, len(h) - 1)]
            for k, v in vals.items():
                tot[k] = tot.get(k, 0.0) + v
        A = tot.get("A_valid", 0.0)
        out.append({"depth": d, "I_D": lref ** 2 * tot["int_abs_K"] / A if A else None,
                    "I_D_plus": lref ** 2 * tot["int_K_plus"] / A if A else None,
                    "I_D_minus": lref ** 2 * tot["int_K_minus"] / A if A else None})
    return out


def assess_brep(source, lref=None, h_f=DEFAULT_HF, k_f=DEFAULT_KF, faces=None, with_fields=True,
                progress=None, order=None, rtol=None, max_depth=None, audit=True, display_deflection=None,
                cross_checks=True, jobs=None, protocol=None, depth_limit=None, point_budget=None):
    """Signature of a BRep (file path, Part.Shape, FreeCAD object, or a BRepInput already
    loaded, whose face selection then stands) by exact quadrature.

    lref: reference length in the shape's units (None: automatic); faces: 1-based face
    numbers; order, rtol, max_depth, protocol, depth_limit, point_budget: quadrature settings
    (DEFAULT_QUADRATURE: refinement by the error down to 30 levels within 8 million points,
    tolerances on the shape's totals; protocol "paper": each face to max_depth 5, rechecked at
    max_depth + 1); audit: nested-neighbourhood audit at degenerate points;
    display_deflection: tessellation of the display-only fields (default 5e-3 of the
    bounding-box diagonal; the automatic L_ref always comes from the nodes of a tessellation
    at 2e-2 of it, display.SAMPLE_DEFLECTION); cross_checks: derivatives
    against OpenCascade and the independent area per face; jobs: worker processes for the
    faces (None: automatic, see face_pool.resolve_jobs; the values do not depend on it).
    """
    try:
        return _assess_brep(source, lref, h_f, k_f, faces, with_fields, progress, order, rtol, max_depth,
                            audit, display_deflection, cross_checks, jobs, protocol, depth_limit, point_budget)
    finally:
        if isinstance(source, ReadInChild):
            source.close()


def threshold_band(fields, th, width=THRESHOLD_BAND):
    """Share of the valid area where K lies within width tau_K of +-tau_K, and where H lies
    within width tau_H of +-tau_H, at the display tessellation's nodes (each node weighted by
    a third of its triangles' areas): the area whose class would change with a threshold
    moved by that much, i.e. how sensitive the class fractions are to the thresholds
    (eq:class_thresholds)."""
    P, T = np.asarray(fields.points, float), np.asarray(fields.triangles, int)
    if T.size == 0:
        return None
    a = 0.5 * np.linalg.norm(np.cross(P[T[:, 1]] - P[T[:, 0]], P[T[:, 2]] - P[T[:, 0]]), axis=1)
    w = np.bincount(T.ravel(), weights=np.repeat(a / 3.0, 3), minlength=len(P))
    w = np.where(np.asarray(fields.valid, bool), w, 0.0)
    total = w.sum()
    if total <= 0:
        return None
    K, H = np.abs(np.asarray(fields.K, float)), np.abs(np.asarray(fields.H, float))
    with np.errstate(invalid="ignore"):
        k_band = np.abs(K - th.tau_K) <= width * th.tau_K
        h_band = np.abs(H - th.tau_H) <= width * th.tau_H
    return {"relative_width": width, "K_band_area_fraction": float(w[k_band].sum() / total),
            "H_band_area_fraction": float(w[h_band].sum() / total),
            "source": "display tessellation nodes"}


def faces_to_refine(faces, rtol):
    """Indices of the faces to refine again with more points: for every quantity whose
    summed error estimate exceeds its total's tolerance (_global_tolerance), the faces whose
    refinement the point budget stopped, largest error first, until the others' errors fit
    half that tolerance."""
    out = set()
    for q in QUANTITIES:
        tol = _global_tolerance(faces, q, rtol)
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


def face_point_budgets(opts, weights):
    """Point budget of each face (None: no limit, the paper's protocol): its share weights
    (n,) of opts["point_budget"], at least FACE_POINT_FLOOR."""
    if opts.get("protocol") == "paper" or opts.get("point_budget") is None:
        return [None] * len(weights)
    total = int(opts["point_budget"])
    return [max(min(FACE_POINT_FLOOR, total), int(total * w)) for w in weights]


def quadrature_options(order=None, rtol=None, max_depth=None, protocol=None, depth_limit=None,
                       point_budget=None):
    """DEFAULT_QUADRATURE with the given settings (None: the default); InputError on a value
    out of range."""
    opts = dict(DEFAULT_QUADRATURE)
    given = (("order", order), ("rtol", rtol), ("max_depth", max_depth), ("protocol", protocol),
             ("depth_limit", depth_limit), ("point_budget", point_budget))
    opts.update({k: v for k, v in given if v is not None})
    if opts["protocol"] not in PROTOCOLS:
        raise InputError("unknown quadrature protocol %r (known: %s)" % (opts["protocol"], ", ".join(PROTOCOLS)))
    if int(opts["depth_limit"]) < 1 or int(opts["point_budget"]) < 1:
        raise InputError("depth limit and point budget must be >= 1, got %r and %r"
                         % (opts["depth_limit"], opts["point_budget"]))
    opts["depth_limit"], opts["point_budget"] = int(opts["depth_limit"]), int(opts["point_budget"])
    return opts


def _assess_brep(source, lref, h_f, k_f, faces, with_fields, progress, order, rtol, max_depth, audit,
                 display_deflection, cross_checks, jobs, protocol=None, depth_limit=None, point_budget=None):
    progress = progress or null_progress
    timings = {}
    t0 = time.perf_counter()
    opts = quadrature_options(order, rtol, max_depth, protocol, depth_limit, point_budget)
    opts["audit"] = bool(audit)
    progress(0.0, "reading BRep")
    if isinstance(source, ReadInChild):
        if source.unsupported is None:
            inp = RecordedShape(source)
        else:  # a face the records do not describe: read the file here
            source.close()
            inp = read_and_start(source.path, source.faces)
    else:
        inp = source if isinstance(source, BRepInput) else load_brep(source, faces)
    recorded = isinstance(inp, RecordedShape)
    if recorded:
        set_reported_versions(inp.versions)
    timings["read"] = inp.read_seconds if inp.read_seconds is not None else time.perf_counter() - t0

    t = time.perf_counter()
    n_jobs = resolve_jobs(jobs, len(inp.faces))
    cost = [f.patch_count if recorded else patch_count(f) for _, f in inp.faces]
    # Faces are set up while the L_ref tessellation runs beside (their set-up does not
    # depend on the thresholds): all of them when they are integrated here, else, from
    # records (numpy alone: nothing here can crash in the geometry kernel, whose crashes the
    # worker processes isolate), smallest first, as many set-ups and area rules as are done
    # before the tessellation is (the worker processes, forked later, take them over).
    # a face assessed alone is integrated in patch groups, which share the CPUs instead of
    # faces (several faces: the faces do)
    groups = len(inp.faces) == 1
    if n_jobs == 1:
        setups = [set_up_or_none(f, cross_checks) for _, f in inp.faces]
        if recorded:  # and the field at the first quadtree levels, while L_ref is on its way
            for s in setups:
                if s is not None:
                    s.prefetch_until(inp.lref_ready, opts["order"], groups, opts["max_depth"])
    else:
        setups = set_up_until(inp.lref_ready if recorded else None, [f for _, f in inp.faces], cost,
                              cross_checks)
    if recorded:
        size = inp.size
        occ_areas = None
        lref_samples = inp.lref_samples()
    else:
        boxes = shape_boxes(inp.shape, inp.faces)  # before anything is tessellated here
        size = boxes[0].DiagonalLength
        occ_areas = [occ_face_area(f) for _, f in inp.faces]  # while a started L_ref tessellation runs
        # the automatic L_ref from the nodes of one fixed tessellation, whatever the display
        lref_samples = tessellation_samples([f for _, f in inp.faces], SAMPLE_DEFLECTION * size,
                                            inp.lref_tessellation)
    if lref_samples is None:
        raise InputError("the faces could not be sampled (no tessellation): empty or invalid faces")
    ref = resolve_reference_length(lref_samples["points"], lref_samples["node_area"], explicit=lref,
                                   units=inp.units.get("working_unit", ""))
    deflection = (display_deflection or DISPLAY_DEFLECTION * size) if with_fields else None

    def display_field(i, face):  # the face's field, from its set-up when it has one here
        if setups[i] is not None:
            return setups[i].ff
        return face.field() if recorded else FaceField(face)

    def display_samples(meshes=None):  # exact fields at the display nodes (display.sample_faces)
        out = None
        try:
            out = sample_faces([(n, display_field(i, f)) for i, (n, f) in enumerate(inp.faces)], deflection, meshes)
        except Exception:  # a face without a field or a display mesh: the others, one by one
            parts = []
            for i, (n, f) in enumerate(inp.faces):
                try:
                    parts.append(sample_faces([(n, display_field(i, f))], deflection,
                                              None if meshes is None else [meshes[i]]))
                except Exception:  # that face is NOT EVALUATED in its record (left_out)
                    continue
            parts = [p for p in parts if p is not None]
            if parts:
                out = merge_samples(parts)
        if out is None:
            raise InputError("the faces could not be sampled (no display tessellation): empty or invalid faces")
        return out

    samples = None
    if with_fields and not recorded:  # from records: after the quadrature, with the display meshes
        samples = display_samples()
    th = Thresholds(ref.value, h_f, k_f)
    timings["display_samples"] = time.perf_counter() - t

    t = time.perf_counter()
    # progress weights: OpenCascade's face areas where known, else the faces' patch counts
    known = occ_areas is not None and None not in occ_areas
    areas = np.maximum(np.array(occ_areas if known else cost, dtype=float), 0.0)
    weights = areas / areas.sum() if areas.sum() > 0 else np.full(len(areas), 1.0 / len(areas))
    group_jobs = resolve_jobs(jobs, GROUPS) if groups else 1
    face_budgets = face_point_budgets(opts, weights)
    done = [0.0, 0]  # weight and number of the faces finished

    def face_work(i):
        number, face = inp.faces[i]
        if n_jobs == 1:  # progress inside the face; from workers only as faces finish
            def sub(fr, msg=""):
                progress(0.05 + 0.9 * (done[0] + weights[i] * fr), "face %d: %s" % (number, msg))
            sub(0.0, "integrating")
        else:
            sub = null_progress
        try:
            return assess_face(number, face, th, ref.value, opts, sub, groups, group_jobs, cross_checks,
                               setups[i], face_budgets[i]).detach()
        except Exception as exc:  # a face OpenCascade or its data cannot give: left out, recorded
            return left_out_face(number, face, exc, setups[i])

    def finished(i, f):
        done[0] += weights[i]
        done[1] += 1
        progress(0.05 + 0.9 * done[0], "face %d %s (%d of %d faces)"
                 % (f.number, "done" if isinstance(f, FaceAssessment) else "NOT EVALUATED", done[1], len(inp.faces)))

    if n_jobs > 1:
        progress(0.05, "integrating %d faces in %d processes" % (len(inp.faces), n_jobs))
    prov = {}

    def shape_records():  # in this process while the workers integrate
        tp = time.perf_counter()
        if not recorded:
            prov.update(shape_provenance(inp.shape, inp.faces, occ_areas, boxes))
        timings["provenance"] = time.perf_counter() - tp

    results = map_faces(face_work, len(inp.faces), n_jobs, cost=cost, on_done=finished,
                        labels=["Face%d" % n for n, _ in inp.faces], while_waiting=shape_records)
    for _ in range(BUDGET_ROUNDS if opts["protocol"] != "paper" else 0):
        # the faces that carry the shape's excess error, again with more points
        ev = [i for i, r in enumerate(results) if not isinstance(r, LeftOutFace)]
        redo = [ev[k] for k in faces_to_refine([results[i] for i in ev], opts["rtol"])]
        if not redo:
            break
        used = sum(results[i].quad.n_points for i in ev)
        share = np.array([sum(f.quad.errors[q] for q in QUANTITIES[2:5]) for f in (results[i] for i in redo)])
        share = share / share.sum() if share.sum() > 0 else np.full(len(redo), 1.0 / len(redo))
        for i, w in zip(redo, share):
            face_budgets[i] = max(BUDGET_GROWTH * face_budgets[i], int(max(opts["point_budget"] - used, 0) * w))
        progress(0.95, "refining %d face(s) that carry the shape's error: %s"
                 % (len(redo), ", ".join("Face%d" % inp.faces[i][0] for i in redo)))
        again = map_faces(lambda k: face_work(redo[k]), len(redo), min(n_jobs, len(redo)),
                          cost=[face_budgets[i] for i in redo], labels=["Face%d" % inp.faces[i][0] for i in redo])
        for i, f in zip(redo, again):
            if isinstance(f, LeftOutFace):
                results[i] = f
                continue
            # the earlier and the finer integration must agree within their error estimates
            f.disagreement = {q: [results[i].quad.values[q], f.quad.values[q]] for q in QUANTITIES
                              if abs(f.quad.values[q] - results[i].quad.values[q])
                              > DISAGREEMENT_SAFETY * (f.quad.errors[q] + results[i].quad.errors[q])
                              + 1e-12 * abs(f.quad.values[q])}
            results[i] = f
    if recorded:  # what the reading process made last: provenance, OpenCascade's values
        tp = time.perf_counter()
        late = inp.late(with_fields, display_deflection)
        prov.update(late["provenance"])
        if with_fields:
            samples = display_samples(late["display"])
        timings["provenance"] += time.perf_counter() - tp
    timings["quadrature"] = time.perf_counter() - t

    results, left_out = evaluated_faces(results)
    integrals = SurfaceIntegrals.zero()
    for f in results:
        integrals = integrals + f.result.integrals()
    values = signature_values(integrals, ref.value)
    history = refinement_history(results, ref.value)
    validity = metric_validity(results, integrals, values, opts, history)
    rows = face_records(results, integrals, ref.value, th.tau_H, th.tau_K)
    if left_out:
        rows = sorted(rows + [f.record() for f in left_out], key=lambda r: r["face"])
        mark_left_out(validity, left_out, integrals.represented_area)

    t = time.perf_counter()
    prov["units"] = inp.units
    prov["faces"] = rows
    prov["concentrated_faces"] = concentrated_faces(rows)
    if prov["concentrated_faces"]:
        names = ", ".join("Face%d (%.2g %% of area, %.2g %% of the |K| integral)"
                          % (c["face"], 100 * c["area_share"], 100 * c["K_share"]) for c in prov["concentrated_faces"])
        for m in ("I_D", "I_D_plus", "I_D_minus"):
            rec = validity[m]
            rec.reason = (rec.reason + "; " if rec.reason else "") + "curvature concentrated on " + names
    prov["degenerate_points"] = [{"face": f.number, **f.degenerate.to_dict()} for f in results if f.degenerate]
    prov["quadrature"] = [{"face": f.number, **f.quad.to_dict()} for f in results]
    if cross_checks:
        prov["cross_checks"] = [f.cross_check for f in results]
    timings["provenance"] += time.perf_counter() - t

    fields = display_fields(samples, ref.value, th) if with_fields else None
    if fields is not None:
        band = threshold_band(fields, th)
        for m in ("a_flat", "a_single", "a_elliptic", "a_saddle"):
            validity[m].evidence["threshold_band"] = band
    points = sum(r["points"] for r in rows)
    if left_out:
        warnings_left_out = ["face(s) %s NOT EVALUATED: %s" % (",".join(str(f.number) for f in left_out),
                                                               "; ".join(f.reason for f in left_out))]
    else:
        warnings_left_out = []
    timings["total"] = time.perf_counter() - t0
    info = dict(inp.info)
    prov["reading"] = ("OpenCascade in a separate process; faces integrated from its plain records "
                       "(poles, knots, weights, p-curves)" if recorded else "OpenCascade in this process")
    warnings = ([ref.warning] if ref.warning else []) + warnings_left_out
    progress(1.0, "done: %d quadrature points" % points)
    return Assessment(input=info, reference_length=ref, thresholds=th, integrals=integrals,
                      validity=validity, fields=fields, provenance=prov,
                      options={**opts, "recheck_depth": opts["max_depth"] + 1 if opts["protocol"] == "paper" else None,
                               "jobs": n_jobs,
                               "group_jobs": min(group_jobs, max(f.quad.n_main for f in results)),
                               "display_deflection": deflection,
                               "lref_sample_deflection": SAMPLE_DEFLECTION * size, "points_evaluated": points},
                      timings=timings, warnings=warnings)


def merge_samples(parts):
    """One display.sample_faces dict from several (triangle indices offset, arrays joined)."""
    out, offset = {k: [] for k in parts[0]}, 0
    for p in parts:
        for k, v in p.items():
            out[k].append(v + offset if k == "triangles" else v)
        offset += len(p["points"])
    return {k: np.concatenate(v) for k, v in out.items()}


def probe_point(shape, face_number, point, lref, h_f=DEFAULT_HF, k_f=DEFAULT_KF):
    """Exact K, H, k1, k2, q_D and class at the point of Face<face_number> nearest to point."""
    from ..core.thresholds import classify
    from ..freecad_env import import_freecad
    FreeCAD = import_freecad()
    face = shape.Faces[face_number - 1]
    u, v = face.Surface.parameter(FreeCAD.Vector(*point))
    f = FaceField(face)(np.array([u]), np.array([v]))
    th = Thresholds(lref, h_f, k_f)
    K, H = float(f["K"][0]), float(f["H"][0])
    cls = int(classify(np.array([K]), np.array([H]), th.tau_H, th.tau_K, f["regular"])[0])
    return {"face": face_number, "u": u, "v": v, "K": K, "H": H, "k1": float(f["k1"][0]),
            "k2": float(f["k2"][0]), "q_D": abs(K) * lref ** 2, "class_id": cls,
            "regular": bool(f["regular"][0]), "exact": True}
