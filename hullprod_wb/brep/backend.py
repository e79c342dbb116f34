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

from ..core.constants import DEFAULT_HF, DEFAULT_KF
from ..core.errors import InputError
from ..core.integrals import SurfaceIntegrals
from ..core.progress import null_progress
from ..core.reference_length import resolve_reference_length
from ..core.result import Assessment
from ..core.signature import signature_values
from ..core.thresholds import Thresholds
from ..freecad_env import set_reported_versions
from . import plain_records, singular
from .display import (DISPLAY_DEFLECTION, SAMPLE_DEFLECTION, display_fields, sample_faces,
                      tessellation_samples)
from .face_field import FaceField
from .face_pool import map_faces, map_forked, resolve_jobs
from .loading import BRepInput, load_brep
from .left_out import EmptyDomain, LeftOutFace, evaluated_faces, left_out_face, mark_left_out
from .provenance import occ_face_area, shape_boxes, shape_provenance
from .patches import Patches
from .plain_records import ReadInChild, cross_check_params, occ_reference, patch_count
from .recorded_shape import FaceRecord, RecordedShape
from .budget import (BUDGET_ROUNDS, disagreement, face_point_budgets, faces_to_refine, grown_budgets,
                     quadrature_options)
from .cubature import GROUPS, QUANTITIES, NodePrefetch, integrate, patch_area, patch_groups
from .metric_rules import concentrated_faces, face_records, metric_validity, refinement_history, threshold_band
from .trimmed_domain import TrimmedDomain

#: Tree depth and class-line halvings of a graded neighbourhood quadrant.
QUADRANT_MAX_DEPTH = 5
QUADRANT_CLASS_DEPTH = 1
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


def _assess_brep(source, lref, h_f, k_f, faces, with_fields, progress, order, rtol, max_depth, audit,
                 display_deflection, cross_checks, jobs, protocol=None, depth_limit=None, point_budget=None):
    progress = progress or null_progress
    timings = {}
    t0 = time.perf_counter()
    opts = quadrature_options(order, rtol, max_depth, protocol, depth_limit, point_budget)
    opts["audit"] = bool(audit)
    progress(0.0, "reading BRep")
    if isinstance(source, ReadInChild):  # every face comes as records or OpenCascade's data
        inp = RecordedShape(source)
    else:
        inp = source if isinstance(source, BRepInput) else load_brep(source, faces)
    recorded = isinstance(inp, RecordedShape)
    if recorded:
        set_reported_versions(inp.versions)
    timings["read_s"] = inp.read_seconds if inp.read_seconds is not None else time.perf_counter() - t0

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
    ref = resolve_reference_length(lref_samples["points"], lref_samples["triangles"], lref_samples["node_area"], explicit=lref,
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
    timings["display_samples_s"] = time.perf_counter() - t

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
        timings["provenance_s"] = time.perf_counter() - tp

    results = map_faces(face_work, len(inp.faces), n_jobs, cost=cost, on_done=finished,
                        labels=["Face%d" % n for n, _ in inp.faces], while_waiting=shape_records)
    for _ in range(BUDGET_ROUNDS if opts["protocol"] != "paper" else 0):
        # the faces that carry the shape's excess error, again with more points
        ev = [i for i, r in enumerate(results) if not isinstance(r, LeftOutFace)]
        redo = [ev[k] for k in faces_to_refine([results[i] for i in ev], opts["rtol"])]
        if not redo:
            break
        grown = grown_budgets([results[i].quad for i in redo], [face_budgets[i] for i in redo],
                              opts["point_budget"], sum(results[i].quad.n_points for i in ev))
        for i, b in zip(redo, grown):
            face_budgets[i] = b
        progress(0.95, "refining %d face(s) that carry the shape's error: %s"
                 % (len(redo), ", ".join("Face%d" % inp.faces[i][0] for i in redo)))
        again = map_faces(lambda k: face_work(redo[k]), len(redo), min(n_jobs, len(redo)),
                          cost=[face_budgets[i] for i in redo], labels=["Face%d" % inp.faces[i][0] for i in redo])
        for i, f in zip(redo, again):
            if isinstance(f, LeftOutFace):
                results[i] = f
                continue
            # the earlier and the finer integration must agree within their error estimates
            f.disagreement = disagreement(results[i].quad, f.quad)
            results[i] = f
    if recorded:  # what the reading process made last: provenance, OpenCascade's values
        tp = time.perf_counter()
        late = inp.late(with_fields, display_deflection)
        prov.update(late["provenance"])
        if with_fields:
            samples = display_samples(late["display"])
        timings["provenance_s"] += time.perf_counter() - tp
    timings["quadrature_s"] = time.perf_counter() - t

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
    timings["provenance_s"] += time.perf_counter() - t

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
    timings["total_s"] = time.perf_counter() - t0
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
