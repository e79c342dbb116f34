"""Display samples of BRep faces: every node of an evaluated face carries a finite field."""
import numpy as np
import pytest

from conftest import needs_freecad, shared_hull

pytestmark = needs_freecad


def _sphere_samples(radius):
    import FreeCAD  # noqa: F401  (before Part)
    import Part
    from hullprod_wb.brep.display import DISPLAY_DEFLECTION, sample_faces
    from hullprod_wb.brep.geometry.face_field import FaceField
    from hullprod_wb.brep.reading.occ_records import display_mesh
    face = Part.makeSphere(radius).Faces[0]
    ff = FaceField(face)
    return sample_faces([(1, ff)], DISPLAY_DEFLECTION, meshes=[display_mesh(face, 0.05 * radius)])


def test_pole_nodes_of_a_sphere_take_the_field_of_a_moved_point():
    """A sphere's parameterisation collapses at its poles (J = 0): the nodes there keep
    their position and show K = 1/R^2 like every other node, not NaN."""
    s = _sphere_samples(2.0)
    assert s["valid"].all()
    assert np.isfinite(s["K"]).all() and np.isfinite(s["H"]).all()
    np.testing.assert_allclose(s["K"], 0.25, rtol=1e-6)
    # the poles are among the nodes, at their own positions
    assert np.isclose(np.abs(s["points"][:, 2]).max(), 2.0, rtol=1e-9)


def test_fields_csv_has_no_invalid_sample_on_a_valid_face(tmp_path):
    """`analyze --out` on a hull whose faces have collapsed sides: no fields.csv row with
    valid != 1 or a NaN on a face whose record is VALID or VALID*."""
    import csv
    import json
    import subprocess
    from conftest import ROOT
    path = shared_hull("brep/dtmb5415_half_overture.igs")
    p = subprocess.run([ROOT + "/hullprod", "analyze", path, "--out", str(tmp_path)], capture_output=True,
                       text=True, timeout=600)
    assert p.returncode == 0, p.stderr[-2000:]
    doc = json.loads((tmp_path / "signature.json").read_text())
    status = {r["face"]: r["status"] for r in doc["provenance"]["faces"]}
    with open(tmp_path / "fields.csv") as fh:
        rows = [r for r in csv.DictReader(fh) if status.get(int(float(r["face_id"]))) in ("VALID", "VALID*")]
    assert rows
    bad = [r for r in rows if r["valid"] != "1" or any(v.lower() == "nan" for v in r.values())]
    assert bad == []
