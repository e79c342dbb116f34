"""A BRep file assessed from the plain records its reading process sent (record_reader).

RecordedShape stands where backend.assess_brep otherwise has a loaded BRepInput: faces
(with OpenCascade's cross-check values), description, bounding-box size, the automatic-L_ref
nodes, and (late) the display tessellation and the provenance, with OpenCascade's face
areas. Its faces (FaceRecord) give the same FaceField and TrimmedDomain as the Part
faces would, built from the same numbers. A face sent as OpenCascade's data (another
surface type, a p-curve the records do not describe) and a face whose trimmed domain
needs OpenCascade itself (a p-curve whose conversion fails its check) are rebuilt from
that data in the process that integrates them (part_face); no file is read here.
"""
from .geometry.face_field import FaceField
from .geometry.surface_eval import SurfaceEvaluator
from .geometry.trimmed_domain import TrimmedDomain


class FaceRecord:
    """One face of a RecordedShape: number, surface_type, patch_count, occ_reference
    (OpenCascade's values at the cross-check points), and field(), domain() (None when it
    needs the Part face: part_face())."""

    def __init__(self, rec, shape):
        self.rec, self.shape = rec, shape
        self.number = rec.number
        self.surface_type = rec.surface_type
        self.patch_count = rec.patch_count
        self.occ_reference = rec.occ_reference
        self.as_data = rec.as_data  # sent as OpenCascade's data, not as numbers

    def field(self):
        if self.as_data:
            return FaceField(self.part_face())
        return FaceField(None, SurfaceEvaluator.from_record(self.rec), self.surface_type)

    def domain(self, evaluator=None):
        if self.as_data:
            return None
        return TrimmedDomain.from_record(self.rec, evaluator or SurfaceEvaluator.from_record(self.rec))

    def part_face(self):
        """The Part.Face, rebuilt from the data the reading process sent (FreeCAD is loaded
        here for it)."""
        return self.shape.part_faces("part_faces" if self.as_data else "described_faces")[self.rec.part]


class RecordedShape:
    """The records of a BRep file (record_reader.ReadInChild, whose first frame has arrived):
    info, units, faces [(number, FaceRecord)], size (bounding-box diagonal), read_seconds,
    user_cache (FreeCAD's user cache folder on the reading side);
    lref_samples(), display() and late() read the later frames, lref_ready() tells whether
    the first of them is there."""

    def __init__(self, reader):
        first = reader.faces_frame()
        self.reader = reader
        self.path, self.selection = reader.path, reader.faces
        self.info, self.units = first.info, first.units
        self.size, self.read_seconds = first.size, first.read_seconds
        self.versions = first.versions
        self.user_cache = first.user_cache
        self.faces = [(r.number, FaceRecord(r, self)) for r in first.faces]
        self._late = self._display = None
        self._part_faces = {}

    def part_faces(self, key):
        """The faces the reading process sent as data under key ("part_faces" in the first
        frame, "described_faces" in the second), as Part.Face objects, rebuilt once."""
        if key not in self._part_faces:
            from .reading.loading import faces_from_bytes
            frame = self.reader.faces_frame() if key == "part_faces" else self.reader.lref_frame()
            self._part_faces[key] = faces_from_bytes(getattr(frame, key))
        return self._part_faces[key]

    def lref_ready(self):
        """Whether lref_samples() would return without waiting for the reading process."""
        return self.reader.lref_ready()

    def lref_samples(self):
        """dict(points, triangles, node_area) of the automatic-L_ref tessellation
        (display.tessellation_samples)."""
        from .display import node_samples
        frame = self.reader.lref_frame()
        return node_samples(frame.lref_points, frame.lref_triangles)

    def display(self, display_deflection):
        """The record_reader.DisplayFrame (display: per face occ_records.display_mesh, and
        display_deflection) from the reading process, or from another one read for it when
        this one was started without fields."""
        if self._display is None:
            frame = self.reader.display_frame()
            if frame.display is None:
                from .reading.record_reader import ReadInChild
                again = ReadInChild(self.path, self.selection, True, display_deflection, self.reader.cache)
                try:
                    frame = again.display_frame()
                finally:
                    again.close()
            self._display = frame
        return self._display

    def late(self):
        """The record_reader.LateFrame (the provenance, with OpenCascade's face areas) from
        the reading process, which then ends."""
        if self._late is None:
            self._late = self.reader.late_frame()
            self.reader.close()
        return self._late

    def close(self):
        self.reader.close()
