"""A BRep file assessed from the plain records its reading process sent (plain_records).

RecordedShape stands where backend.assess_brep otherwise has a loaded BRepInput: faces
(with OpenCascade's cross-check values), description, bounding-box size, the automatic-L_ref
nodes, and (late) the provenance, with OpenCascade's face areas, and the display
tessellation. Its faces (FaceRecord) give the same FaceField and TrimmedDomain as the Part
faces would, built from the same numbers; a face whose trimmed domain needs OpenCascade
itself (a p-curve whose conversion fails its check) is read again here (part_face).
"""
from .face_field import FaceField
from .surface_eval import SurfaceEvaluator
from .trimmed_domain import TrimmedDomain


class FaceRecord:
    """One face of a RecordedShape: number, surface_type, patch_count, occ_reference
    (OpenCascade's values at the cross-check points), and field(), domain() (None when it
    needs the Part face: part_face())."""

    def __init__(self, rec, path):
        self.rec, self.path = rec, path
        self.number = rec["number"]
        self.surface_type = rec["surface_type"]
        self.patch_count = rec["patch_count"]
        self.occ_reference = rec["occ_reference"]

    def field(self):
        return FaceField(None, SurfaceEvaluator.from_record(self.rec), self.surface_type)

    def domain(self, evaluator=None):
        return TrimmedDomain.from_record(self.rec, evaluator or SurfaceEvaluator.from_record(self.rec))

    def part_face(self):
        """The Part.Face, read from the file in this process (FreeCAD is loaded here)."""
        from .loading import load_brep
        return load_brep(self.path, [self.number]).faces[0][1]


class RecordedShape:
    """The records of a BRep file (plain_records.ReadInChild, whose first frame has arrived
    and is supported): info, units, faces [(number, FaceRecord)], size (bounding-box
    diagonal), read_seconds; lref_samples() and late() read the later frames, lref_ready()
    tells whether the first of them is there."""

    def __init__(self, reader):
        first = reader.frame(0)
        self.reader = reader
        self.path, self.selection = reader.path, reader.faces
        self.info, self.units = first["info"], first["units"]
        self.size, self.read_seconds = first["size"], first["read_seconds"]
        self.versions = first["versions"]
        self.faces = [(r["number"], FaceRecord(r, reader.path)) for r in first["faces"]]
        self._late = None

    def lref_ready(self):
        """Whether lref_samples() would return without waiting for the reading process."""
        return self.reader.ready(1)

    def lref_samples(self):
        """dict(points, node_area) of the automatic-L_ref tessellation (display.tessellation_samples)."""
        from .display import node_samples, tessellation_samples
        from .lref_samples import SAMPLE_DEFLECTION
        frame = self.reader.frame(1)
        if frame is None:  # the reading process died: tessellate here
            return tessellation_samples([f for _, f in self._part_input().faces], SAMPLE_DEFLECTION * self.size)
        return node_samples(frame["lref_points"], frame["lref_triangles"])

    def late(self, with_fields, display_deflection):
        """dict(provenance, and with fields display (per face: plain_records.display_mesh) and
        display_deflection), from the reading process, or made here when it ended before
        sending them."""
        if self._late is None:
            frame = self.reader.frame(2)
            self.reader.close()
            if frame is None or (with_fields and "display" not in frame):
                frame = self._late_here(with_fields, display_deflection)
            self._late = frame
        return self._late

    def _late_here(self, with_fields, display_deflection):
        from .plain_records import DISPLAY_DEFLECTION, display_mesh
        from .provenance import shape_boxes, shape_provenance
        inp = self._part_input()
        boxes = shape_boxes(inp.shape, inp.faces)
        out = {}
        if with_fields:
            deflection = display_deflection or DISPLAY_DEFLECTION * self.size
            out["display"] = [display_mesh(f, deflection) for _, f in inp.faces]
            out["display_deflection"] = deflection
        out["provenance"] = shape_provenance(inp.shape, inp.faces, None, boxes)
        return out

    def _part_input(self):
        from .loading import load_brep
        return load_brep(self.path, self.selection)

    def close(self):
        self.reader.close()
