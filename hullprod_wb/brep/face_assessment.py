"""Assessment of one BRep face (paper section 4.1, 4.3): adaptive boundary-fitted cubature
of the face with the neighbourhoods of its degenerate points excluded, each neighbourhood
quadrant through its graded map, each pinch point's box through whitened polar coordinates, grading where a refinement stalled at a knot-grid node,
the nested-neighbourhood audit of the degenerate set, and the cross-checks."""
from ..core.progress import null_progress
from .validity import singular
from .validity.cross_checks import face_cross_checks
from .validity.pinch_points import pinch_triangles
from .cubature import QUANTITIES, integrate, patch_groups
from ..core.processes import map_forked
from .face_result import PIECE_BUDGET_SHARE, CombinedQuadrature, FaceAssessment, final_result, part_budget
from .face_setup import FaceSetup
from .geometry.trimmed_domain import TrimmedDomain

#: Tree depth and class-line halvings of a graded neighbourhood quadrant.
QUADRANT_MAX_DEPTH = 5
QUADRANT_CLASS_DEPTH = 1
#: Rounds of grading at knot-grid nodes where a face's refinement stalled.
STALL_ROUNDS = 2


def assess_face(number, face, thresholds, lref, opts, progress=null_progress, groups=False, group_jobs=1,
                cross_checks=True, setup=None, point_budget=None):
    """Integrate one face; neighbourhoods of degenerate points and hot spots are integrated
    separately through a graded map (singular.GradedQuadrantField), then audited. With
    groups, a face of many patches is integrated in patch groups (cubature.patch_groups),
    in group_jobs processes (processes.map_forked; the values do not depend on it), and
    this process computes the area cross-check while it waits for the others (unless the
    setup has it). cross_checks: attach face_cross_checks. face: a Part.Face, or a
    recorded_shape.FaceRecord (the same field and domain from its records, and OpenCascade's
    cross-check values). setup: its FaceSetup when already made."""
    s = setup or FaceSetup(face)
    quad = _integrate_face(s, thresholds, opts, progress, groups, group_jobs, cross_checks, point_budget)
    needs = [quad.budget_needed()]  # of every integration the result depends on
    for _ in range(STALL_ROUNDS if not opts.paper and opts.audit else 0):
        # a refinement that stalled at a knot-grid node: graded there and audited (VALID* or
        # SINGULAR), instead of ever smaller cells (paper section 4.3)
        pts = singular.points_from_refinement([final_result(p) for p in quad.parts[:quad.n_main]], s.domain,
                                              s.u_breaks, s.v_breaks, s.deg.graded_points)
        if not pts or not s.add_stalled_points(pts):
            break
        quad = _integrate_face(s, thresholds, opts, progress, groups, group_jobs, False, point_budget)
        needs.append(quad.budget_needed())
    ff, domain, deg, quads, gu, gv = s.ff, s.domain, s.deg, s.quads, s.gu, s.gv
    audits = []
    if deg and opts.audit:
        totals = dict(quad.values)
        # the pinch points' boxes are integrated in triangles: their quadrants serve the audit
        audit_quads = quads + singular.neighbourhood_quadrants(deg, domain, s.u_breaks, s.v_breaks, deg.interior)
        for p in deg.audited_points:
            audits.append(singular.audit_point(ff, p, audit_quads, totals, lref, thresholds.tau_H,
                                               thresholds.tau_K, order=opts.order))
        for side in deg.sides:
            audits.append(singular.probe_side(ff, domain, side, s.u_breaks, s.v_breaks))
    f = FaceAssessment(number, ff, domain, (gu, gv), deg, quads, quad, audits)
    f.budget_needed = None if None in needs else max(needs)  # None without a budget too
    if cross_checks:
        f.cross_check = face_cross_checks(f, s.check.get("rule"), s.check.get("seconds", 0.0),
                                          reference=face.occ_reference if s.recorded else None)
    return f


def _integrate_face(s, thresholds, opts, progress, groups, group_jobs, area_check, point_budget):
    """CombinedQuadrature of a set-up face (FaceSetup s): its patch groups (in group_jobs
    processes when groups), then each neighbourhood quadrant through its graded map and
    each pinch point's triangles through whitened polar coordinates (pinch_points). With
    the budget protocol (not opts.paper) the groups refine by their error down
    to opts.depth_limit within point_budget points (split between the groups); with the
    paper's, to max_depth with a recheck one level deeper (section 5.2)."""
    ff, domain, quads, gu, gv, main_field = s.ff, s.domain, s.quads, s.gu, s.gv, s.main_field
    kw = dict(order=opts.order, rtol=opts.rtol, max_depth=opts.max_depth, recheck=True)
    groups = patch_groups(s.patches.size) if groups else [None]
    mkw = dict(kw)
    if not opts.paper:
        mkw.update(depth_limit=opts.depth_limit, point_budget=part_budget(point_budget, len(groups)))
    prefetch = s.prefetch if s.prefetch is not None and len(s.prefetch) == len(groups) else [None] * len(groups)

    def main_part(g):  # progress from the group integrated in this process
        return integrate(domain, main_field, thresholds.tau_H, thresholds.tau_K, u_breaks=gu, v_breaks=gv,
                         progress=progress if g == 0 else None, patch_range=groups[g], prefetch=prefetch[g], **mkw)

    # the area rule is independent of the adaptive cubature: while other groups finish
    parts = map_forked(main_part, len(groups), group_jobs, while_waiting=s.area_check if area_check else None)
    n_main = len(parts)
    # Each neighbourhood quadrant or pinch triangle may use up to a 1/(2 n) share of the
    # face's tolerance; its map makes its integrand smooth, so a shallow tree resolves it.
    pieces = [singular.GradedQuadrantField(ff, q) for q in quads]
    pieces += [t for p, ru, rv in s.pinches for t in pinch_triangles(ff, p, ru, rv)]
    unit = TrimmedDomain.rectangle(0.0, 1.0, 0.0, 1.0) if pieces else None
    main_values = {k: sum(final_result(p).values[k] for p in parts) for k in QUANTITIES}
    share = {k: abs(v) / (2.0 * max(len(pieces), 1)) for k, v in main_values.items()}
    qkw = dict(kw, max_depth=min(opts.max_depth, QUADRANT_MAX_DEPTH), class_max_depth=QUADRANT_CLASS_DEPTH)
    if not opts.paper:  # refined by the error too, within a share of the face's points
        qkw.update(depth_limit=opts.depth_limit, point_budget=part_budget(point_budget, PIECE_BUDGET_SHARE))
    for piece in pieces:
        parts.append(integrate(unit, piece, thresholds.tau_H, thresholds.tau_K, reference=share, **qkw))

    return CombinedQuadrature(parts, n_main)
