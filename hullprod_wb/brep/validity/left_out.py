"""Faces left out of a BRep assessment: a face whose geometry OpenCascade or its data cannot
give (an area that cannot be computed, a p-curve missing, no surface, an integration that
raises) is NOT EVALUATED in its record, with the reason and an estimate of its area; the
hull's metrics are formed over the evaluated faces and say which faces they leave out and
what share of the area those carry (paper section 4.3: validity travels with the number).
"""
from ...core.errors import InputError
from ...core.validity import Qualification, Status
from .cross_checks import area_rule
from ..geometry.trimmed_domain import EmptyDomain

#: Tessellation deflection of a left-out face's polygon area estimate, relative to its size.
POLYGON_ESTIMATE_DEFLECTION = 1e-3


class LeftOutFace:
    """A face that was not evaluated: its number, the reason (one line), the estimate of its
    area (None when no estimate could be made) and how that estimate was made."""

    def __init__(self, number, reason, area_estimate=None, method=None, surface_type=None):
        self.number, self.reason = int(number), reason
        self.area_estimate = None if area_estimate is None else float(area_estimate)
        self.method, self.surface_type = method, surface_type

    def record(self):
        """The face's row of provenance['faces'] (the same keys as an evaluated face's)."""
        return {"face": self.number, "surface_type": self.surface_type, "evaluation": None, "area": None,
                "valid_area": None, "area_share": None, "K_share": None, "I_D": None, "I_D_plus": None,
                "I_D_minus": None, "a_C": None, "status": Status.NOT_EVALUATED.value, "converged": False,
                "points": 0, "reason": self.reason, "area_estimate": self.area_estimate,
                "area_estimate_method": self.method}


def _one_line(exc):
    text = " ".join(str(exc).split())
    return "%s: %s" % (type(exc).__name__, text) if text else type(exc).__name__


def _polygon_area(face):
    """Sum of the triangle areas of OpenCascade's tessellation of a Part face, or None."""
    try:
        size = max(face.BoundBox.DiagonalLength, 1e-300)
        pts, tris = face.tessellate(POLYGON_ESTIMATE_DEFLECTION * size)
    except Exception:  # the face cannot be tessellated either
        return None
    total = 0.0
    for a, b, c in tris:
        p, q, r = pts[a], pts[b], pts[c]
        total += 0.5 * (q - p).cross(r - p).Length
    return total if tris else None


def left_out_face(number, face, exc, setup=None, set_up=None):
    """LeftOutFace of a face whose assessment raised exc: its area from our own order-8
    tensor Gauss-Legendre rule over its trimmed domain when the face can be set up (setup, or
    set_up(face): the face's FaceSetup), else
    from the triangles of OpenCascade's tessellation (a Part face), else unknown. A face
    whose trimmed domain has no extent has area 0 exactly."""
    surface_type = getattr(face, "surface_type", None)
    if surface_type is None:
        try:
            surface_type = type(face.Surface).__name__
        except Exception:  # no surface at all
            surface_type = "no surface"
    if isinstance(exc, EmptyDomain):
        return LeftOutFace(number, "its trimmed domain has no extent (%s): a face of zero area" % exc,
                           0.0, "trimmed domain without extent", surface_type or "no surface")
    reason = _one_line(exc)
    try:
        s = setup or set_up(face)
        area = float(area_rule(s.ff, s.domain, s.gu, s.gv)[0])
        if area == area and abs(area) != float("inf"):
            return LeftOutFace(number, reason, area, "tensor Gauss-Legendre order 8 on its trimmed domain",
                               surface_type)
    except EmptyDomain as again:
        return left_out_face(number, face, again, set_up=set_up)
    except Exception:  # the set-up itself fails: estimate from a tessellation
        pass
    if hasattr(face, "tessellate"):
        area = _polygon_area(face)
        if area is not None:
            return LeftOutFace(number, reason, area, "OpenCascade tessellation (triangle areas)", surface_type)
    return LeftOutFace(number, reason, None, None, surface_type)


def evaluated_faces(results):
    """(evaluated face assessments, left-out faces) of the results of a BRep assessment;
    an InputError when no face could be evaluated."""
    left = [r for r in results if isinstance(r, LeftOutFace)]
    done = [r for r in results if not isinstance(r, LeftOutFace)]
    if not done:
        raise InputError("no face could be evaluated: %s"
                         % "; ".join("Face%d: %s" % (f.number, f.reason) for f in left))
    return done, left


def left_out_qualification(left_out, evaluated_area):
    """The Qualification of every metric for the faces left out: CAUTION (from VALID or
    VALID*) naming them and their share of the area, estimate / (evaluated area + the
    estimates), or 'unknown' when a face has no estimate; faces of zero estimated area
    change no status and are named in the evidence."""
    estimates = [f.area_estimate for f in left_out]
    known = [a for a in estimates if a is not None]
    total = float(evaluated_area) + sum(known)
    if None in estimates:
        share, share_text = None, "unknown share of the area"
    else:
        share = sum(known) / total if total > 0 else None
        share_text = ("%.3g %% of the area" % (100 * share)) if share is not None else "unknown share of the area"
    names = ",".join(str(f.number) for f in left_out)
    zero = share == 0.0
    reason = ("face(s) %s carry no area and are left out" % names if zero else
              "computed over the evaluated faces; face(s) %s NOT EVALUATED (%s)" % (names, share_text))
    evidence = [{"face": f.number, "reason": f.reason, "area_estimate": f.area_estimate,
                 "area_estimate_method": f.method} for f in left_out]
    return Qualification("faces_not_evaluated", reason,
                         {"faces_not_evaluated": evidence, "not_evaluated_area_share": share}, caution=not zero)
