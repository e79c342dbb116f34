"""The set-up of a BRep face's integration, made before the class thresholds are known:
its field and trimmed domain, knot lines, degenerate set, the neighbourhood quadrants of
its degenerate points and the boxes of its pinch points (paper section 4.3), and its
boundary-fitted patches."""
import functools
import time

import numpy as np

from ..core.errors import InputError
from .validity import singular
from .validity.cross_checks import area_rule
from .cubature import NodePrefetch, patch_groups
from .geometry.face_field import FaceField
from .cubature.patches import Patches
from .recorded_shape import FaceRecord
from .geometry.trimmed_domain import EmptyDomain, TrimmedDomain, polygon_domain


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
        if domain is None:
            if self.recorded:  # a domain that needs OpenCascade itself: the face, read here
                if not part_face:
                    raise _NeedsPartFace()
                face = face.part_face()
                self.recorded = False
            ff = FaceField(face)
            try:
                domain = TrimmedDomain.from_face(face)
            except InputError as exc:
                domain = polygon_domain(face, " ".join(str(exc).split()))
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
        """Quadrants of the degenerate set's graded points, the boxes of its pinch points
        (pinch_points: each as (point, r_u, r_v), when its four quadrants lie inside the
        domain), the patches' lines gu, gv and the field with the neighbourhoods excluded."""
        ff, domain, u_breaks, v_breaks = self.ff, self.domain, self.u_breaks, self.v_breaks
        self.quads = singular.neighbourhood_quadrants(self.deg, domain, u_breaks, v_breaks) if self.deg else []
        self.pinches = []
        for p in self.deg.interior:
            around = singular.neighbourhood_quadrants(self.deg, domain, u_breaks, v_breaks, [p])
            if len(around) == 4:
                self.pinches.append((p, around[0].ru, around[0].rv))
        self.gu, self.gv = u_breaks, v_breaks
        self.main_field = ff
        boxes = [q.box for q in self.quads] + [(p[0] - ru, p[0] + ru, p[1] - rv, p[1] + rv)
                                                for p, ru, rv in self.pinches]
        if boxes:
            b = np.asarray(boxes, dtype=float)
            self.gu = np.unique(np.concatenate([np.asarray(u_breaks, float), b[:, 0], b[:, 1]]))
            self.gv = np.unique(np.concatenate([np.asarray(v_breaks, float), b[:, 2], b[:, 3]]))
            self.main_field = singular.ExcludedBoxesField(ff, boxes)
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
