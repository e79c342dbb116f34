"""Faces with a seam read the same on every FreeCAD: a seam edge gives both of its p-curves
to the trim loops (occ_records.face_pcurves), whether the wire lists it twice among its
children (FreeCAD 0.20) or once (FreeCAD 1.x)."""
import math

import pytest

from conftest import needs_freecad

pytestmark = needs_freecad


def _part():
    from hullprod_wb.freecad_env import import_freecad
    import_freecad()
    import Part
    from FreeCAD import Vector
    return Part, Vector


def seam_faces():
    """name -> (face, L_ref, expected area, I_D, I_D+, I_D-) of faces with seams (the torus
    two, the others one; the sphere's poles too); exact values from the surfaces' closed forms (K = 1 on the unit
    sphere, 0 on the cylinder, int |K| dA = 8 pi and int K+- dA = 4 pi on the torus)."""
    Part, V = _part()
    L = 2.0
    torus_area = 4.0 * math.pi ** 2 * 3.0 * 1.0
    return {
        "sphere": (Part.makeSphere(1.0).Faces[0], L, 4.0 * math.pi, L * L, L * L, 0.0),
        "cylinder": (Part.makeCylinder(1.0, 2.0).Faces[0], L, 4.0 * math.pi, 0.0, 0.0, 0.0),
        "torus": (Part.makeTorus(3.0, 1.0).Faces[0], L, torus_area, 8.0 * math.pi * L * L / torus_area,
                  4.0 * math.pi * L * L / torus_area, 4.0 * math.pi * L * L / torus_area),
        "periodic B-spline": (Part.makeCylinder(1.0, 2.0).Faces[0].toNurbs().Faces[0], L, 4.0 * math.pi,
                              0.0, 0.0, 0.0),
    }


def children_listed_once(face):
    """Each wire's edges as FreeCAD 1.x lists its children: a seam edge once."""
    out = []
    for wire in face.Wires:
        edges = []
        for e in wire.childShapes():
            if not any(o.isSame(e) for o in edges):
                edges.append(e)
        out.append(edges)
    return out


def pcurve_ends(pairs):
    return [(e.Orientation, round(pc[1], 12), round(pc[2], 12),
             tuple(round(c, 12) for p in (pc[0].value(pc[1]), pc[0].value(pc[2])) for c in (p.x, p.y)))
            for e, pc in pairs]


def test_a_seam_gives_both_of_its_pcurves_on_every_freecad():
    from hullprod_wb.brep.reading.occ_records import face_pcurves
    for name, (face, *_) in seam_faces().items():
        seams = [e for e in face.Edges if e.isSeam(face)]
        assert len(seams) == (2 if name == "torus" else 1), name
        here = face_pcurves(face)
        once = face_pcurves(face, children_listed_once(face))
        for seam in seams:
            on_seam = [(e, pc) for e, pc in here if e.isSame(seam)]
            assert len(on_seam) == 2, name
            assert {e.Orientation for e, _ in on_seam} == {"Forward", "Reversed"}
            first, second = (pc[0].value(pc[1]) for _, pc in on_seam)
            assert abs(first.x - second.x) > 1.0 or abs(first.y - second.y) > 1.0  # the domain's two sides
        assert sorted(pcurve_ends(once)) == sorted(pcurve_ends(here)), name


def test_seam_faces_read_from_step_give_their_exact_values(tmp_path):
    from hullprod_wb import assess
    for name, (face, lref, area, I_D, I_Dp, I_Dm) in seam_faces().items():
        path = str(tmp_path / (name.replace(" ", "_") + ".step"))
        face.exportStep(path)
        r = assess(path, lref=lref, with_fields=False)
        assert r.integrals.represented_area == pytest.approx(area, rel=1e-4), name
        for metric, value in (("I_D", I_D), ("I_D_plus", I_Dp), ("I_D_minus", I_Dm)):
            assert r.signature[metric] == pytest.approx(value, rel=1e-4, abs=1e-9), (name, metric)
            assert r.validity[metric].status.value in ("VALID", "VALID*"), (name, metric, r.validity[metric].reason)
        assert not any("do not close" in (v.reason or "") for v in r.validity.values()), name
