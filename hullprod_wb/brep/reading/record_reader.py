"""The plain records of a BRep file (occ_records), made by OpenCascade in a child process.

A BRep file's assessment needs OpenCascade only to read the geometry. So a child
(reader_process: forked from a clean process, else a fresh interpreter) reads the file with
FreeCAD, turns every face into plain numbers (occ_records.face_record), makes the
tessellations and the OpenCascade values the records need, and sends them to the parent
through a pipe, while the parent loads numpy and the numerical modules. A face that
occ_records does not describe (another surface type, a planar face, a p-curve of another
type or none) travels as OpenCascade's binary BRep data (loading.faces_to_bytes) and is
rebuilt in the process that integrates it, which then loads FreeCAD (recorded_shape);
either way the fields and domains are built from the same numbers as from the faces read
in that process.

The child sends four frames: FacesFrame, the face records (occ_records.FaceData, with
OpenCascade's values at the cross-check points and the edges' vertices, and the faces sent
as data) and the file's description; LrefFrame, the nodes of the automatic-L_ref
tessellation (and the described faces as data too, for a trimmed domain that needs
OpenCascade); then, at the lowest priority, what is only needed at the end: DisplayFrame,
the display tessellation, and LateFrame, the provenance with OpenCascade's face areas. The
records come first, so that the parent sets the faces up while the tessellation runs
(ReadInChild.lref_ready tells it whether the next frame is there); the display tessellation
before the provenance, so that the parent samples the fields on it while the child makes
the rest. A child
that dies (an exit or a signal in OpenCascade) makes the parent raise ReaderDied.

Nothing here imports numpy: the reading side never loads it.
"""
import hashlib
import os
import time
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Optional

from ...core.errors import InputError
from ...freecad_env import import_freecad, user_cache_folder, versions
from .loading import faces_to_bytes, load_brep, shape_to_bytes
from .lref_samples import SAMPLE_DEFLECTION, tessellate_faces
from .occ_records import (CROSS_CHECK_POINTS, DISPLAY_DEFLECTION, FaceData, display_mesh, face_record,
                          occ_reference, patch_count)
from .provenance import occ_face_area, shape_boxes, shape_provenance
from .record_keys import area_key
from .reader_process import STAGE, ReaderProcess


#: The key of a frame's record in what the reading process sends (beside reader_process.STAGE).
FRAME = "frame"


@dataclass(frozen=True)
class FacesFrame:
    """The first frame: the file's description (info) and units, its faces' records
    (occ_records.FaceData), the bounding-box diagonal (size), the software versions of the
    reading side, the seconds the file took to read, the faces sent as OpenCascade's
    data (loading.faces_to_bytes; None when every face is described by numbers), and
    FreeCAD's user cache folder (freecad_env.user_cache_folder)."""

    info: dict
    units: dict
    faces: list
    size: float
    versions: dict
    read_seconds: float
    part_faces: Optional[bytes]
    user_cache: Optional[str] = None


@dataclass(frozen=True)
class LrefFrame:
    """The second frame: the automatic-L_ref tessellation (lref_samples.tessellate_faces:
    flat points and triangles), the seconds it took, and the described faces as
    OpenCascade's data too (None when there are none), for a trimmed domain that needs
    OpenCascade."""

    lref_points: object
    lref_triangles: object
    seconds: float
    described_faces: Optional[bytes]


@dataclass(frozen=True)
class DisplayFrame:
    """The third frame: when the fields were asked for, the display tessellation of every
    face (occ_records.display_mesh) and its deflection (None otherwise)."""

    display: Optional[list] = None
    display_deflection: Optional[float] = None


@dataclass(frozen=True)
class LateFrame:
    """The last frame: the shape's provenance (with OpenCascade's face areas)."""

    provenance: dict


def part_record(face, why, number, part):
    """The FaceData (kind "part") of a face sent as OpenCascade's own data
    (loading.faces_to_bytes) instead of plain numbers (another surface type, a planar face,
    a p-curve of another type or none, or a face face_record could not describe), the
    reason why; the face itself travels in the frame's part_faces, at index part. Its
    data_digest is face_data_digest's."""
    try:
        surface_type = type(face.Surface).__name__
    except Exception:  # no surface OpenCascade can give: the parent's set-up says so
        surface_type = "unknown"
    try:
        reference = occ_reference(face)
    except Exception:  # no parameter range: nothing to compare
        reference = [None] * CROSS_CHECK_POINTS
    return FaceData(number=number, surface_type=surface_type, kind="part", part=part,
                    patch_count=patch_count(face), occ_reference=reference, reason=why,
                    data_digest=face_data_digest(face))


def face_data_digest(face):
    """The SHA-256 of a face's own OpenCascade data (loading.shape_to_bytes), taken before
    any tessellation adds to it; None where OpenCascade cannot write it (never stored)."""
    try:
        return hashlib.sha256(shape_to_bytes(face)).hexdigest()
    except Exception:  # no data OpenCascade can write
        return None


def record_frames(path, faces, with_fields, display_deflection, cache=None):
    """In the reading process (reader_process): read path with FreeCAD and yield the three
    frames of its records (see the module doc); cache: the faces' store's choice
    (result_store.open_store), where OpenCascade's face areas are kept."""
    import_freecad()
    t = time.perf_counter()
    inp = load_brep(path, faces, here=True)
    seconds = time.perf_counter() - t
    yield {STAGE: "describing the faces"}
    for frame in _frames(inp, with_fields, display_deflection, seconds, cache):
        yield frame


def _frames(inp, with_fields, display_deflection, read_seconds, cache=None):
    """The three frames of the records of a loaded BRepInput (see the module doc), each
    with what comes after it (reader_process.STAGE)."""
    boxes = shape_boxes(inp.shape, inp.faces)  # before any tessellation, as when read here
    size = float(boxes[0].DiagonalLength)
    faces, as_data, described = [], [], []
    for number, face in inp.faces:
        try:
            rec, why = face_record(face, number, len(described))
        except Exception as exc:  # OpenCascade cannot give what the record needs: the face as data
            rec, why = None, "an OpenCascade error (%s)" % " ".join(str(exc).split())
        if rec is None:
            rec = part_record(face, why, number, len(as_data))
            as_data.append(face)
        else:
            described.append(face)
        faces.append(rec)
    store = reading_store(cache)
    # the faces' own data, before any tessellation adds to it: their keys in the store
    digests = None if store is None else [r.data_digest if r.as_data else face_data_digest(f)
                                          for r, (_, f) in zip(faces, inp.faces)]
    # the records first: the parent sets the faces up while the tessellation runs here
    yield {FRAME: FacesFrame(inp.info, inp.units, faces, size, versions(), read_seconds,
                             faces_to_bytes(as_data) if as_data else None, user_cache_folder()),
           STAGE: "tessellating the faces"}
    t = time.perf_counter()
    pts, tris = tessellate_faces([f for _, f in inp.faces], SAMPLE_DEFLECTION * size)
    # with the described faces as data too, for a trimmed domain that needs OpenCascade
    # (recorded_shape.FaceRecord.part_face): here before any worker process starts
    yield {FRAME: LrefFrame(pts, tris, time.perf_counter() - t, faces_to_bytes(described) if described else None),
           STAGE: "making the display tessellation, the faces' areas and the edge report"}
    # the rest is needed only at the end: give the CPUs to the integration meanwhile
    try:
        os.nice(19)
    except OSError:
        pass
    display = deflection = None
    lookups = StoreLookups(store)
    if with_fields:
        deflection = display_deflection or DISPLAY_DEFLECTION * size
        with lookups("display_meshes_from_store"):
            display = display_meshes([f for _, f in inp.faces], deflection, SAMPLE_DEFLECTION * size, store, digests)
    yield {FRAME: DisplayFrame(display, deflection), STAGE: "computing the faces' areas and the edge report"}
    with lookups("occ_areas_from_store"):
        areas = face_areas(inp.faces, store, digests)
    with lookups("edge_reports_from_store"):
        provenance = shape_provenance(inp.shape, inp.faces, areas, boxes, store, digests)
    provenance.update(lookups.record)
    yield {FRAME: LateFrame(provenance)}


def display_meshes(faces, deflection, lref_deflection, store=None, digests=None):
    """occ_records.display_mesh of each face, in order. With a store and each face's digest
    of its OpenCascade data (taken before any tessellation), a face's mesh is kept there
    under a key of its digest, the two deflections (the automatic-L_ref tessellation's,
    lref_deflection, came first) and the digests of the faces sharing an edge with it, with
    whether each comes before it (record_keys.display_key): OpenCascade meshes a shared edge
    once for the faces that share it, so a face's mesh depends on them and on their order,
    and on nothing else. A face meshed here has its earlier neighbours meshed first, as a
    run without the store does, so its mesh is the one that run makes."""
    if store is None or digests is None:
        return [display_mesh(f, deflection) for f in faces]
    from .record_keys import display_key
    neighbours = edge_neighbours(faces)
    occ = versions().get("OCC")
    meshed, out = [False] * len(faces), []
    for k, face in enumerate(faces):
        def mesh():
            for i in neighbours[k]:
                if i < k and not meshed[i]:
                    display_mesh(faces[i], deflection)  # its shared edges as a run without the store has them
                    meshed[i] = True
            meshed[k] = True
            return display_mesh(face, deflection)
        near = [(i < k, digests[i]) for i in neighbours[k]]
        known = digests[k] is not None and all(d is not None for _, d in near)
        out.append(store.made(display_key(digests[k], deflection, lref_deflection, occ, near) if known else None,
                              mesh))
    return out


def edge_neighbours(faces):
    """For each face, the indices of the other faces that share an edge with it (the same
    OpenCascade edge, Shape.isSame), ascending."""
    by_hash, out = {}, [set() for _ in faces]
    for k, face in enumerate(faces):
        for e in face.Edges:
            for i, other in by_hash.setdefault(e.hashCode(), []):
                if i != k and other.isSame(e):
                    out[k].add(i)
                    out[i].add(k)
            by_hash[e.hashCode()].append((k, e))
    return [sorted(n) for n in out]


class StoreLookups:
    """with lookups(name): the store's hits and misses in the block, as record[name]
    ({"hits", "misses"}; nothing without a store)."""

    def __init__(self, store):
        self.store, self.record = store, {}

    @contextmanager
    def __call__(self, name):
        c = self.store.counts if self.store is not None else None
        before = (c.hits, c.misses) if c is not None else None
        yield
        if c is not None:
            self.record[name] = {"hits": c.hits - before[0], "misses": c.misses - before[1]}


def reading_store(cache):
    """The faces' store of the reading process (result_store.open_store of the parent's
    choice), or None."""
    from ...core.result_store import open_store
    try:
        return open_store(cache, user_cache_folder())[0]
    except InputError:  # the parent reports a store that is not a folder
        return None


def face_areas(faces, store=None, digests=None):
    """OpenCascade's area of each face (provenance.occ_face_area; None where it has none): a
    face's area depends on the face alone, so with a store and the faces' data digests it is
    kept there (record_keys.area_key) and taken from there when the face comes again."""
    if store is None or digests is None:
        return [occ_face_area(f) for _, f in faces]
    occ = versions().get("OCC")
    return [store.made(None if d is None else area_key(d, occ), lambda f=face: ("area", occ_face_area(f)))[1]
            for (_, face), d in zip(faces, digests)]


class ReadInChild:
    """The records of a BRep file, read by a child started now (reader_process: forked from
    a clean process, else a fresh interpreter; see the module doc).

    faces_frame(), lref_frame(), display_frame() and late_frame() return the four frames
    (FacesFrame, LrefFrame, DisplayFrame, LateFrame) as the child sent them, waiting for
    them; lref_ready() tells whether lref_frame() would wait. An InputError of the child (an
    unreadable file, a bad face number) is raised here with its message; a child that ends
    before sending a frame raises ReaderDied (an InputError) naming the file and what
    OpenCascade was doing.
    """

    FRAMES = 4

    def __init__(self, path, faces=None, with_fields=True, display_deflection=None, cache=None):
        self.path, self.faces = path, faces
        self.with_fields, self.display_deflection = with_fields, display_deflection
        self.cache = getattr(cache, "folder", cache)  # a ResultStore's folder, a folder, False or None
        self._frames = []
        self._child = ReaderProcess(path, (__name__, "record_frames"),
                                    (path, faces, with_fields, display_deflection, self.cache))

    def faces_frame(self):
        """FacesFrame: the faces' records and the file's description."""
        return self._frame(0)

    def lref_frame(self):
        """LrefFrame: the automatic-L_ref tessellation and the described faces as data."""
        return self._frame(1)

    def display_frame(self):
        """DisplayFrame: the display tessellation."""
        return self._frame(2)

    def late_frame(self):
        """LateFrame: the provenance."""
        return self._frame(3)

    def lref_ready(self):
        """Whether lref_frame() would return without waiting for the child (or the child has
        ended)."""
        return self._ready(1)

    def _ready(self, k):
        """Whether frame k has arrived, or the next frame has begun to arrive."""
        if len(self._frames) > k:
            return True
        if len(self._frames) < k:
            return False
        return self._child.ready()

    def _frame(self, k):
        while len(self._frames) <= k:
            self._frames.append(self._child.receive(last=len(self._frames) == self.FRAMES - 1)[FRAME])
        return self._frames[k]

    def close(self):
        """Stop (if still running) and reap the child."""
        self._child.close()
