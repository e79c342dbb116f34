"""Native-BRep realization of the signature (paper section 4.1).

Exact derivatives of each face (batched NURBS or closed form), H and K from the
fundamental forms (eq:brephk), adaptive boundary-fitted Gauss-Legendre cubature over the
trimmed domain (eq:brep_surface_integral), graded refinement and a nested-neighbourhood
audit at degenerate points (face_assessment), and per-metric validity (section 4.3,
metric_rules).

assess_brep takes a BrepRun through its stages: read the shape; set its faces up while the
L_ref tessellation runs; L_ref, the display samples and the thresholds; integrate the faces
(in worker processes, this process making the shape's records meanwhile); refine the faces
that carry the shape's error; the records the reading process made last; the Assessment.
"""
import time
from contextlib import contextmanager
from dataclasses import dataclass, field
from typing import Optional

import numpy as np

from ..core.constants import DEFAULT_HF, DEFAULT_KF
from ..core.errors import InputError
from ..core.file_checks import fewer_faces
from ..core.integrals import SurfaceIntegrals
from ..core.progress import null_progress
from ..core.result_store import open_store
from ..core.reference_length import resolve_reference_length
from ..core.result import Assessment
from ..core.signature import signature_values
from ..core.thresholds import Thresholds
from ..core.validity import Qualification, qualify_all
from ..freecad_env import set_reported_versions, user_cache_folder, versions
from .validity.budget import (BUDGET_ROUNDS, QuadratureOptions, disagreement, face_point_budgets, faces_to_refine,
                              grown_budgets, quadrature_options)
from .cubature import GROUPS
from .display import (DISPLAY_DEFLECTION, SAMPLE_DEFLECTION, display_fields, face_display_mesh, sample_faces,
                      sample_meshes, tessellation_samples)
from .face_assessment import assess_face
from ..core.exact_keys import HALF
from .face_keys import display_samples_key, face_keys, geometry_digest, settings_digest
from .geometry.face_field import FaceField
from ..core.processes import resolve_jobs
from .face_result import FaceAssessment
from .face_setup import FaceSetup, set_up_or_none, set_up_until
from .stored_faces import stored_or_assessed
from .validity.left_out import LeftOutFace, evaluated_faces, left_out_face, left_out_qualification
from .reading.loading import BRepInput, load_brep
from .validity.metric_rules import concentrated_faces, face_records, metric_validity, refinement_history, threshold_band
from .reading.occ_records import patch_count
from .reading.provenance import occ_face_area, shape_boxes, shape_provenance
from .reading.record_reader import ReadInChild
from .recorded_shape import RecordedShape


#: Bar spans: the first integration of every face, then the budget protocol's rounds of
#: re-integration (each round an equal part); display and records take the rest.
INTEGRATION_SPAN = (0.05, 0.85)
REFINEMENT_SPAN = (0.85, 0.95)


@dataclass
class BrepRun:
    """One BRep assessment on its way through its stages (assess_brep).

    shape: a RecordedShape (RecordedRun: from the plain records of the reading process) or a
    loaded BRepInput (LoadedRun); opts: the quadrature options (budget.quadrature_options,
    with audit); progress(fraction, message); started: perf_counter() at the start; the
    caller's with_fields, display_deflection, cross_checks, jobs and cache (the faces' store:
    result_store.open_store's choice). The stages add: store (a ResultStore or None) and
    store_source, geometry (each face's face_keys.geometry_digest, None without a store),
    settings (face_keys.settings_digest), from_store (the numbers of the faces whose
    results came from the store), n_jobs
    (processes.resolve_jobs), cost (each face's patch count), setups (each face's FaceSetup
    made here, or None), size (the bounding-box diagonal), occ_areas (OpenCascade's face
    areas where known here), ref (the reference length), thresholds, deflection (of the
    display tessellation; None without fields), samples (display.sample_faces), weights
    (each face's share of the progress), group_jobs, face_budgets (points), results (each
    face's FaceAssessment or LeftOutFace), provenance, and every stage's seconds (timings).
    What the kind of shape decides: READING, face_cost, lref_ready, face_field,
    lref_samples, samples_before_quadrature, shape_records, samples_while_integrating,
    late_records and user_cache.
    """

    shape: object
    opts: QuadratureOptions
    progress: object
    started: float
    with_fields: bool
    display_deflection: Optional[float]
    cross_checks: bool
    jobs: Optional[int]
    cache: object = None
    timings: dict = field(default_factory=dict)
    store: object = None
    store_source: str = ""
    geometry: list = None
    settings: str = None
    from_store: list = field(default_factory=list)
    n_jobs: int = 1
    cost: list = None
    setups: list = None
    size: float = None
    occ_areas: list = None
    ref: object = None
    thresholds: Thresholds = None
    deflection: Optional[float] = None
    samples: dict = None
    weights: np.ndarray = None
    group_jobs: int = 1
    face_budgets: list = None
    results: list = None
    provenance: dict = field(default_factory=dict)
    done_weight: float = 0.0  # weight and number of the faces finished in the current pass
    done_count: int = 0
    pass_span: tuple = None  # (lo, hi) of the bar for the current pass over faces
    pass_weights: np.ndarray = None  # each face's share of the current pass (0: not in it)
    pass_size: int = 0

    @staticmethod
    def read(source, faces, opts, progress, started, **choices):
        """Stage 1: the shape, from the records of its reading process (a ReadInChild source,
        every face as records or OpenCascade's data: RecordedRun) or loaded here (LoadedRun;
        a BRepInput source's face selection stands), timed as read_s."""
        progress(0.0, "reading BRep")
        if isinstance(source, ReadInChild):
            run = RecordedRun(RecordedShape(source), opts, progress, started, **choices)
            set_reported_versions(run.shape.versions)
        else:
            run = LoadedRun(source if isinstance(source, BRepInput) else load_brep(source, faces), opts,
                            progress, started, **choices)
        read = run.shape.read_seconds
        run.timings["read_s"] = read if read is not None else time.perf_counter() - started
        return run

    @contextmanager
    def timed(self, key):
        """Add the seconds of the with-block to timings[key]."""
        t = time.perf_counter()
        yield
        self.timings[key] = self.timings.get(key, 0.0) + (time.perf_counter() - t)

    @property
    def in_groups(self):
        """A face assessed alone is integrated in patch groups, which share the CPUs instead
        of faces (several faces: the faces do)."""
        return len(self.shape.faces) == 1

    def set_up_faces(self):
        """Stage 2: the faces' set-ups, while the L_ref tessellation runs beside (a set-up does
        not depend on the thresholds): all of them when they are integrated here (and, where
        lref_ready tells when L_ref comes, the field at their first quadtree levels
        meanwhile); else, from records (numpy alone: nothing here can crash in the geometry
        kernel, whose crashes the worker processes isolate), smallest first, as many set-ups
        and area rules as are done before the tessellation is (the worker processes, forked
        later, take them over)."""
        faces = [f for _, f in self.shape.faces]
        self.n_jobs = resolve_jobs(self.jobs, len(faces))
        self.cost = [self.face_cost(f) for f in faces]
        ready = self.lref_ready
        self.store, self.store_source = open_store(self.cache, self.user_cache)
        with self.timed("store_s"):
            self.geometry = [geometry_digest(f) if self.store is not None else None for f in faces]
        # a face whose geometry is in the store is likely to come from it: not set up here
        todo = [i for i, g in enumerate(self.geometry) if g is None or not self.store.has_any(g[:HALF])]
        self.setups = [None] * len(faces)
        if self.n_jobs == 1:
            for i in todo:
                self.setups[i] = set_up_or_none(faces[i], self.cross_checks)
            if ready is not None:
                for s in self.setups:
                    if s is not None:
                        s.prefetch_until(ready, self.opts.order, self.in_groups, self.opts.max_depth)
        else:
            for i, s in zip(todo, set_up_until(ready, [faces[i] for i in todo], [self.cost[i] for i in todo],
                                               self.cross_checks)):
                self.setups[i] = s

    def reference_length(self, lref, h_f, k_f):
        """Stage 3: L_ref (lref, or automatic from the nodes of one fixed tessellation, whatever
        the display), the display deflection, the display samples where they come before the
        quadrature, and the thresholds (h_f, k_f)."""
        samples = self.lref_samples()
        if samples is None:
            raise InputError("the faces could not be sampled (no tessellation): empty or invalid faces")
        self.ref = resolve_reference_length(samples["points"], samples["triangles"], samples["node_area"],
                                            explicit=lref, units=self.shape.units.get("working_unit", ""))
        self.deflection = (self.display_deflection or DISPLAY_DEFLECTION * self.size) if self.with_fields else None
        self.samples_before_quadrature()
        self.thresholds = Thresholds(self.ref.value, h_f, k_f)

    def integrate_faces(self):
        """Stage 4: every face assessed (face_work) in n_jobs worker processes, this process
        making the shape's records meanwhile (shape_records, timed as provenance_s); the
        progress weighted by OpenCascade's face areas where known, else by the faces' patch
        counts."""
        known = self.occ_areas is not None and None not in self.occ_areas
        areas = np.maximum(np.array(self.occ_areas if known else self.cost, dtype=float), 0.0)
        self.weights = areas / areas.sum() if areas.sum() > 0 else np.full(len(areas), 1.0 / len(areas))
        self.group_jobs = resolve_jobs(self.jobs, GROUPS) if self.in_groups else 1
        self.face_budgets = face_point_budgets(self.opts, self.weights)
        n = len(self.shape.faces)
        if self.store is not None:
            self.settings = settings_digest(self.ref.value, self.thresholds, self.opts, self.in_groups,
                                            self.cross_checks, versions().get("OCC"), type(self).__name__)
        self.start_pass(INTEGRATION_SPAN, self.weights, n)
        if self.n_jobs > 1:
            self.progress(0.05, "integrating %d faces in %d processes" % (n, self.n_jobs))
        self.results = self.stored_or_assessed(list(range(n)), self.cost, self._timed_shape_records)

    def key(self, i):
        """Face i's keys in the store with its current point budget (face_keys.FaceKeys;
        None: not stored)."""
        g = self.geometry[i] if self.store is not None else None
        return None if g is None else face_keys(g, self.settings, self.face_budgets[i])

    def stored_or_assessed(self, todo, cost, while_waiting=None, beside=False):
        """The results of the faces todo (indices) through the store (stored_faces)."""
        return stored_or_assessed(self, todo, cost, while_waiting, beside)

    def _timed_shape_records(self):
        with self.timed("provenance_s"):
            self.shape_records()

    def face_work(self, i):
        """Face i assessed (face_assessment.assess_face) and detached, or its LeftOutFace when
        OpenCascade or its data cannot give it; progress inside the face when the faces are
        integrated here (from worker processes only as faces finish: finished)."""
        number, face = self.shape.faces[i]
        if self.n_jobs == 1:
            sub = self.face_progress(i, number)
            sub(0.0, "integrating")
        else:
            sub = null_progress
        try:
            return assess_face(number, face, self.thresholds, self.ref.value, self.opts, sub, self.in_groups,
                               self.group_jobs, self.cross_checks, self.setups[i], self.face_budgets[i]).detach()
        except Exception as exc:  # a face OpenCascade or its data cannot give: left out, recorded
            return left_out_face(number, face, exc, self.setups[i], FaceSetup)

    def start_pass(self, span, weights, size):
        """A pass over faces filling the bar from span[0] to span[1], face i's share
        weights[i] (summing to 1 over the pass's size faces)."""
        self.pass_span, self.pass_weights, self.pass_size = span, weights, size
        self.done_weight, self.done_count = 0.0, 0

    def pass_fraction(self, done):
        """The bar's fraction when the share done of the current pass is done."""
        lo, hi = self.pass_span
        return lo + (hi - lo) * min(1.0, done)

    def face_progress(self, i, number):
        """progress(fraction, message) inside face i (its number): its share of the pass
        after the faces finished in it."""
        def progress(fraction, message=""):
            self.progress(self.pass_fraction(self.done_weight + self.pass_weights[i] * fraction),
                          "face %d: %s" % (number, message))
        return progress

    def finished(self, i, f, how="done"):
        """Progress as face i finishes (f: its FaceAssessment or LeftOutFace; how it was)."""
        self.done_weight += self.pass_weights[i]
        self.done_count += 1
        self.progress(self.pass_fraction(self.done_weight), "face %d %s (%d of %d faces)"
                      % (f.number, how if isinstance(f, FaceAssessment) else "NOT EVALUATED", self.done_count,
                         self.pass_size))

    def refine_where_the_error_is(self):
        """Stage 5: up to BUDGET_ROUNDS times (never with the paper's protocol), the faces that
        carry the shape's excess error (budget.faces_to_refine) assessed again with grown
        point budgets; a finer integration records where it and the earlier one disagree
        beyond their error estimates (budget.disagreement)."""
        results, budgets, faces = self.results, self.face_budgets, self.shape.faces
        lo, hi = REFINEMENT_SPAN
        for round_ in range(BUDGET_ROUNDS if not self.opts.paper else 0):
            ev = [i for i, r in enumerate(results) if not isinstance(r, LeftOutFace)]
            redo = [ev[k] for k in faces_to_refine([results[i] for i in ev], self.opts.rtol)]
            if not redo:
                break
            grown = grown_budgets([results[i].quad for i in redo], [budgets[i] for i in redo],
                                  self.opts.point_budget, sum(results[i].quad.n_points for i in ev))
            for i, b in zip(redo, grown):
                budgets[i] = b
            share = np.zeros(len(faces))
            cost = np.maximum(np.asarray([budgets[i] for i in redo], float), 0.0)
            share[redo] = cost / cost.sum() if cost.sum() > 0 else 1.0 / len(redo)
            self.start_pass((lo + (hi - lo) * round_ / BUDGET_ROUNDS, lo + (hi - lo) * (round_ + 1) / BUDGET_ROUNDS),
                            share, len(redo))
            self.progress(self.pass_fraction(0.0), "refining %d face(s) that carry the shape's error: %s"
                          % (len(redo), ", ".join("Face%d" % faces[i][0] for i in redo)))
            # the display samples meanwhile, where they are still to make: a round's few faces
            # leave a CPU free for them before long (a single face in a worker too)
            late = self.with_fields and self.samples is None
            again = self.stored_or_assessed(redo, budgets, self.samples_while_integrating if late else None,
                                            beside=late)
            for i, f in zip(redo, again):
                if not isinstance(f, LeftOutFace):
                    f.disagreement = disagreement(results[i].quad, f.quad)
                results[i] = f

    def display_field(self, i, face):
        """Face i's field, from its set-up when it has one here."""
        setup = self.setups[i]
        return setup.ff if setup is not None else self.face_field(face)

    def display_samples(self, meshes=None):
        """Exact fields at the display nodes (display.sample_faces; meshes: the faces' display
        meshes when already made, then each face's samples through the store: stored_display);
        a face without a field or a display mesh is left out of them (it is NOT EVALUATED in
        its record)."""
        faces = self.shape.faces

        def sampled(which):  # the samples of the faces of indices which
            if meshes is None:
                return sample_faces([(faces[i][0], self.display_field(i, faces[i][1])) for i in which],
                                    self.deflection)
            return sample_meshes([faces[i][0] for i in which], [meshes[i] for i in which],
                                 lambda k, mesh: self.stored_display(which[k], mesh))
        out = None
        try:
            out = sampled(range(len(faces)))
        except Exception:  # a face without a field or a display mesh: the others, one by one
            parts = []
            for i in range(len(faces)):
                try:
                    parts.append(sampled([i]))
                except Exception:  # that face is NOT EVALUATED in its record (left_out)
                    continue
            parts = [p for p in parts if p is not None]
            if parts:
                out = merge_samples(parts)
        if out is None:
            raise InputError("the faces could not be sampled (no display tessellation): empty or invalid faces")
        return out

    def stored_display(self, i, mesh):
        """Face i's display samples on mesh (display.face_display_mesh): from the store under
        face_keys.display_samples_key (its geometry, the mesh and the run's kind, bit for bit),
        else made and stored."""
        make = lambda: face_display_mesh(mesh, self.display_field(i, self.shape.faces[i][1]))  # noqa: E731
        g = self.geometry[i] if self.store is not None else None
        if g is None:
            return make()
        with self.timed("store_s"):
            key = display_samples_key(g, mesh, type(self).__name__)
        return self.store.made(key, make)

    def assessment(self):
        """Stage 7: the shape's integrals over the evaluated faces, its signature and their
        validity (metric_rules), the per-face records and the rest of the provenance (timed
        as provenance_s), the display fields, as an Assessment."""
        ref, th, opts = self.ref, self.thresholds, self.opts
        results, left_out = evaluated_faces(self.results)
        integrals = SurfaceIntegrals.zero()
        for f in results:
            integrals = integrals + f.quad.integrals()
        values = signature_values(integrals, ref.value)
        history = refinement_history(results, ref.value)
        validity = metric_validity(results, integrals, values, opts, history, th.k_f)
        rows = face_records(results, integrals, ref.value)
        if left_out:
            rows = sorted(rows + [f.record() for f in left_out], key=lambda r: r["face"])
            qualify_all(validity, left_out_qualification(left_out, integrals.represented_area))
        with self.timed("provenance_s"):
            self.face_provenance(results, rows, validity)
            self.provenance["cache"] = self.store_record()

        fields = display_fields(self.samples, ref.value, th) if self.with_fields else None
        if fields is not None:
            band = threshold_band(fields, th)
            for m in ("a_flat", "a_single", "a_elliptic", "a_saddle"):
                validity[m].evidence["threshold_band"] = band
        points = sum(r["points"] for r in rows)
        warnings = [ref.warning] if ref.warning else []
        if left_out:
            warnings.append("face(s) %s NOT EVALUATED: %s" % (",".join(str(f.number) for f in left_out),
                                                              "; ".join(f.reason for f in left_out)))
        self.timings["total_s"] = time.perf_counter() - self.started
        info = dict(self.shape.info)
        fewer = fewer_faces(info)
        if fewer is not None:  # the file declares faces its reader did not return
            qualify_all(validity, fewer)
            warnings.append(fewer.reason)
        self.provenance["reading"] = self.READING
        self.progress(1.0, "done: %d quadrature points" % points)
        return Assessment(input=info, reference_length=ref, thresholds=th, integrals=integrals,
                          validity=validity, fields=fields, provenance=self.provenance,
                          options={**opts.record(), "recheck_depth": opts.recheck_depth,
                                   "jobs": self.n_jobs,
                                   "group_jobs": min(self.group_jobs, max(f.quad.n_main for f in results)),
                                   "display_deflection": self.deflection,
                                   "lref_sample_deflection": SAMPLE_DEFLECTION * self.size,
                                   "points_evaluated": points},
                          timings=self.timings, warnings=warnings)

    def store_record(self):
        """provenance.cache: the store's folder and where it comes from, its counts this run
        (result_store.StoreCounts), the faces whose results came from it and those it cannot
        hold (no exact key), the reading process's lookups of the display meshes, OpenCascade's
        face areas and the faces' parts of the edge report; the least recently used entries
        pruned beyond its bound."""
        reading = {k: self.provenance.pop(k, None)  # the reading process's lookups
                   for k in ("display_meshes_from_store", "occ_areas_from_store", "edge_reports_from_store")}
        if self.store is None:
            return {"enabled": False, "source": self.store_source}
        if self.store.counts.written:
            self.store.prune()
        return {"enabled": True, "source": self.store_source, "folder": self.store.folder,
                "max_bytes": self.store.max_bytes, **self.store.counts.to_dict(),
                "faces_from_store": sorted(set(self.from_store)),
                "faces_without_key": [n for (n, _), g in zip(self.shape.faces, self.geometry) if g is None],
                **reading}

    def face_provenance(self, results, rows, validity):
        """The provenance's units, per-face records (rows), the faces on which the curvature
        concentrates (named in the reasons of the I_D metrics), degenerate points, the faces'
        quadratures and cross-checks."""
        prov = self.provenance
        prov["units"] = self.shape.units
        prov["faces"] = rows
        prov["concentrated_faces"] = concentrated_faces(rows)
        if prov["concentrated_faces"]:
            names = ", ".join("Face%d (%.2g %% of area, %.2g %% of the |K| integral)"
                              % (c["face"], 100 * c["area_share"], 100 * c["K_share"])
                              for c in prov["concentrated_faces"])
            qualify_all(validity, Qualification("curvature_concentrated", "curvature concentrated on " + names,
                                                caution=False), metrics=("I_D", "I_D_plus", "I_D_minus"))
        prov["degenerate_points"] = [{"face": f.number, **f.degenerate.to_dict()} for f in results if f.degenerate]
        prov["quadrature"] = [{"face": f.number, **f.quad.to_dict()} for f in results]
        if self.cross_checks:
            prov["cross_checks"] = [f.cross_check for f in results]


@dataclass
class RecordedRun(BrepRun):
    """A BrepRun of a shape from the plain records of its reading process (RecordedShape):
    its bounding-box size and L_ref nodes from the records, and after the quadrature
    (late_records) its provenance, with OpenCascade's face areas, and the display meshes."""

    READING = ("OpenCascade in a separate process; faces integrated from its plain records "
               "(poles, knots, weights, p-curves)")

    def face_cost(self, face):
        return face.patch_count

    @property
    def user_cache(self):
        return self.shape.user_cache

    @property
    def lref_ready(self):
        """Whether the reading process has sent the L_ref nodes (RecordedShape.lref_ready)."""
        return self.shape.lref_ready

    def face_field(self, face):
        return face.field()

    def lref_samples(self):
        self.size = self.shape.size
        return self.shape.lref_samples()

    def samples_before_quadrature(self):
        """None: the display samples come with the display meshes (late_records)."""

    def shape_records(self):
        """None: the reading process makes them (late_records)."""

    def samples_while_integrating(self):
        """The display samples on the reading process's display meshes (once), made while the
        faces of a round of stage 5 are integrated in worker processes, timed as
        provenance_s."""
        if self.with_fields and self.samples is None:
            with self.timed("provenance_s"):
                self.samples = self.display_samples(self.shape.display(self.display_deflection).display)

    def late_records(self):
        """Stage 6: what the reading process made last, timed as provenance_s: the display
        samples on its meshes (unless made already), made while it makes the provenance, and
        the provenance, with OpenCascade's values."""
        self.samples_while_integrating()
        with self.timed("provenance_s"):
            self.provenance.update(self.shape.late().provenance)


@dataclass
class LoadedRun(BrepRun):
    """A BrepRun of a shape loaded in this process (BRepInput): its bounding boxes (boxes),
    face areas, L_ref tessellation and display samples made here before the quadrature, and
    its provenance while the worker processes integrate."""

    boxes: list = None

    READING = "OpenCascade in this process"

    def face_cost(self, face):
        return patch_count(face)

    @property
    def user_cache(self):
        return user_cache_folder()

    @property
    def lref_ready(self):
        """None: nothing tells when the L_ref tessellation is done (without workers no face
        prefetches its first levels; with them none is set up here)."""
        return None

    def face_field(self, face):
        return FaceField(face)

    def lref_samples(self):
        faces = self.shape.faces
        self.boxes = shape_boxes(self.shape.shape, faces)  # before anything is tessellated here
        self.size = self.boxes[0].DiagonalLength
        self.occ_areas = [occ_face_area(f) for _, f in faces]  # while a started L_ref tessellation runs
        return tessellation_samples([f for _, f in faces], SAMPLE_DEFLECTION * self.size,
                                    self.shape.lref_tessellation)

    def samples_before_quadrature(self):
        if self.with_fields:
            self.samples = self.display_samples()

    def shape_records(self):
        self.provenance.update(shape_provenance(self.shape.shape, self.shape.faces, self.occ_areas, self.boxes))

    def samples_while_integrating(self):
        """None: the display samples were made before the quadrature."""

    def late_records(self):
        """None: every record of the shape was made here."""


def assess_brep(source, lref=None, h_f=DEFAULT_HF, k_f=DEFAULT_KF, faces=None, with_fields=True,
                progress=None, order=None, rtol=None, max_depth=None, audit=True, display_deflection=None,
                cross_checks=True, jobs=None, protocol=None, depth_limit=None, point_budget=None, cache=None):
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
    faces (None: automatic, see processes.resolve_jobs; the values do not depend on it);
    cache: the faces' store (core.result_store.open_store: None for $HULLPROD_FACE_CACHE or
    FreeCAD's user cache folder, a folder, a ResultStore, or False for none): a face whose
    key (face_keys) is there is taken from it, the others are stored as they are integrated.
    """
    try:
        started = time.perf_counter()
        opts = quadrature_options(order, rtol, max_depth, protocol, depth_limit, point_budget, audit)
        run = BrepRun.read(source, faces, opts, progress or null_progress, started, with_fields=with_fields,
                           display_deflection=display_deflection, cross_checks=cross_checks, jobs=jobs,
                           cache=cache)
        with run.timed("setup_s"):
            run.set_up_faces()
            run.reference_length(lref, h_f, k_f)
        with run.timed("quadrature_s"):
            run.integrate_faces()
            run.refine_where_the_error_is()
            run.progress(REFINEMENT_SPAN[1], "records, display samples and validity")
            run.late_records()
        return run.assessment()
    finally:
        if isinstance(source, ReadInChild):
            source.close()


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
