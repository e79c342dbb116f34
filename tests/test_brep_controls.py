"""Native-BRep verification controls (paper Table tab:brepanalytic), at the accuracy
goals of the BRep issue: I_D relative error <= 1e-9, class fractions within 1e-6."""
import math

import numpy as np
import pytest

from conftest import needs_freecad

pytestmark = needs_freecad

from hullprod_wb.examples.analytic_shapes import (SADDLE_I_D, hemisphere_with_disc,  # noqa: E402
                                                  open_cylinder_face, plane_face, saddle_face, sphere_cap)
from hullprod_wb import assess, selftest  # noqa: E402
from hullprod_wb.examples.builtin import WIGLEY_REFERENCE, half_wigley_shape  # noqa: E402
# Accuracy goals: I_D to 1e-9 relative; class fractions to 1e-6 absolute.
from hullprod_wb.selftest import ATOL_CLASS, RTOL_ID, fractions, statuses  # noqa: E402


def test_plane():
    selftest.check_plane()


def test_unit_sphere_with_degenerate_poles():
    # The poles are a parameterisation degeneracy, not a singular surface: value established.
    selftest.check_unit_sphere()


def test_open_cylinder():
    r = assess(open_cylinder_face(), lref=2.0)
    assert abs(r.signature["I_D"]) < 1e-12
    np.testing.assert_allclose(fractions(r), [0, 1, 0, 0], atol=ATOL_CLASS)
    assert r.integrals.represented_area == pytest.approx(2 * math.pi * 2.0, rel=1e-12)


@pytest.mark.parametrize("kind", ["cone", "B-spline cone", "quarter cone"])
def test_cone_apex_is_developable_not_singular(tmp_path, kind):
    """A cone (radius 10, height 30) read from STEP: K = 0 on its regular surface, and the
    apex, where H grows without bound, carries no |K| (the curvature there is zero to
    rounding): every metric is established, I_D is 0 to rounding and the cone is singly
    curved (its base disc flat)."""
    import Part
    from FreeCAD import Vector
    if kind == "quarter cone":
        solid = Part.makeCone(10, 0, 30, Vector(0, 0, 0), Vector(0, 0, 1), 90)
        shape = Part.Shape([f for f in solid.Faces if "Cone" in f.Surface.TypeId][0])
    else:
        shape = Part.makeCone(10, 0, 30)
        shape = shape.toNurbs() if kind == "B-spline cone" else shape
    path = str(tmp_path / "cone.step")
    shape.exportStep(path)
    r = assess(path, lref=30.0, with_fields=False)
    assert set(statuses(r).values()) <= {"VALID", "VALID*"}, statuses(r)
    assert abs(r.signature["I_D"]) < 1e-9
    # the cone's face is singly curved, the base disc (the smaller face) flat, whatever their
    # surface types: the fractions are the faces' shares
    faces = sorted(r.provenance["faces"], key=lambda f: f["area_share"])
    cone, disc_face = faces[-1], (faces[0] if len(faces) == 2 else None)
    assert cone["a_C"]["single"] == pytest.approx(1.0, abs=ATOL_CLASS)
    if disc_face is not None:
        assert disc_face["a_C"]["flat"] == pytest.approx(1.0, abs=ATOL_CLASS)
    np.testing.assert_allclose(fractions(r), [1.0 - cone["area_share"], cone["area_share"], 0, 0], atol=ATOL_CLASS)
    lateral = math.pi * 10 * math.hypot(10, 30) * (0.25 if kind == "quarter cone" else 1.0)
    disc = 0.0 if kind == "quarter cone" else math.pi * 100
    # exact surfaces to rounding; OpenCascade's B-spline form of a cone approximates it (7.8)
    area_rtol = 1e-4 if kind == "B-spline cone" else 1e-10
    assert r.integrals.represented_area == pytest.approx(disc + lateral, rel=area_rtol)
    if kind != "B-spline cone":
        np.testing.assert_allclose(fractions(r), [disc / (disc + lateral), lateral / (disc + lateral), 0, 0],
                                   atol=ATOL_CLASS)


def test_saddle_closed_form():
    # At the default local tolerance (1e-4) the saddle's smooth integrand is accepted after
    # one refinement, 3.4e-9 from the closed form; the 1e-9 goal needs rtol 1e-6 (measured
    # 4e-13). Both are asserted.
    r = assess(saddle_face(), lref=2.0)
    assert r.signature["I_D"] == pytest.approx(SADDLE_I_D, rel=1e-8)
    selftest.check_saddle()


def test_torus_values_and_class_fractions():
    selftest.check_torus()


#: Independent semi-analytical half-Wigley reference: nested scipy quad of the graph
#: y(x, z), split at the K = 0 roots (epsrel 1e-12): int|K| dA / A.
WIGLEY_I_D_QUAD = 0.3206366224355565 / 0.07439531552478891


def test_half_wigley_reference():
    r = assess(half_wigley_shape(), lref=1.0)
    assert r.signature["I_D"] == pytest.approx(WIGLEY_I_D_QUAD, rel=RTOL_ID)
    # The published reference has 9 significant digits (rounding up to 1.2e-9 relative).
    assert r.signature["I_D"] == pytest.approx(WIGLEY_REFERENCE["I_D"], rel=2e-9)
    assert r.signature["I_D_plus"] == pytest.approx(WIGLEY_REFERENCE["I_D_plus"], rel=3e-9)
    assert r.signature["I_D_minus"] == pytest.approx(WIGLEY_REFERENCE["I_D_minus"], rel=3e-9)
    assert sum(fractions(r)) == pytest.approx(1.0, abs=1e-12)


def test_scale_invariance():
    a = assess(half_wigley_shape(), lref=1.0)
    b = assess(half_wigley_shape(1000.0, 100.0, 62.5), lref=1000.0)
    for m in ("I_D", "I_D_plus", "I_D_minus"):
        assert b.signature[m] == pytest.approx(a.signature[m], rel=1e-9)
    np.testing.assert_allclose(fractions(b), fractions(a), atol=ATOL_CLASS)


def test_orientation_reversal_flips_H_not_K():
    face = half_wigley_shape()
    a = assess(face, lref=1.0)
    b = assess(face.reversed(), lref=1.0)
    assert b.signature["I_D"] == pytest.approx(a.signature["I_D"], rel=1e-12)
    np.testing.assert_allclose(b.fields.K, a.fields.K, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(b.fields.H, -a.fields.H, rtol=1e-9, atol=1e-12)


def test_split_face_gives_the_same_values():
    from hullprod_wb.freecad_env import import_freecad
    import_freecad()
    import Part
    face = half_wigley_shape()
    s = face.Surface.toBSpline() if hasattr(face.Surface, "toBSpline") else face.Surface
    left, right = s.copy(), s.copy()
    left.segment(0.0, 0.37, 0.0, 1.0)
    right.segment(0.37, 1.0, 0.0, 1.0)
    two = Part.Compound([left.toShape(), right.toShape()])
    a = assess(face, lref=1.0)
    b = assess(two, lref=1.0)
    assert b.signature["I_D"] == pytest.approx(a.signature["I_D"], rel=RTOL_ID)
    np.testing.assert_allclose(fractions(b), fractions(a), atol=ATOL_CLASS)


def test_trimmed_circular_caps():
    caps = sphere_cap(1.0, 0.5)
    r = assess(caps, lref=2.0)
    # Two caps of the unit sphere within 0.5 of the axis: area 2 * 2 pi (1 - cos(asin 0.5)).
    area = 2 * 2 * math.pi * (1 - math.cos(math.asin(0.5)))
    numbers = [i + 1 for i, f in enumerate(caps.Faces) if type(f.Surface).__name__ == "Sphere"]
    assert len(numbers) == 2
    a2 = assess(caps, lref=2.0, faces=numbers)
    assert a2.integrals.represented_area == pytest.approx(area, rel=1e-9)
    assert a2.signature["I_D"] == pytest.approx(4.0, rel=RTOL_ID)
    assert r.integrals.represented_area > area


def test_c0_crease_between_hemisphere_and_disc():
    r = assess(hemisphere_with_disc(), lref=2.0)
    # |K| = 1 on the hemisphere (area 2 pi), 0 on the disc (area pi): I_D = 4 * 2pi / 3pi.
    assert r.signature["I_D"] == pytest.approx(8.0 / 3.0, rel=RTOL_ID)
    np.testing.assert_allclose(fractions(r), [1 / 3, 0, 2 / 3, 0], atol=ATOL_CLASS)
    assert r.provenance["edges"]["c0_crease_length"] == pytest.approx(2 * math.pi, rel=1e-6)


def test_display_tessellation_does_not_change_values():
    a = assess(half_wigley_shape(), lref=1.0, display_deflection=1e-2)
    b = assess(half_wigley_shape(), lref=1.0, display_deflection=1e-3)
    assert len(b.fields.points) > len(a.fields.points)
    assert b.vector == a.vector


@pytest.mark.parametrize("ext", [".igs", ".step"])
def test_iges_and_step_round_trip(tmp_path, ext):
    face = half_wigley_shape(1000.0, 100.0, 62.5)
    path = str(tmp_path / ("wigley" + ext))
    face.exportIges(path) if ext == ".igs" else face.exportStep(path)
    r = assess(path, lref=1000.0)
    assert r.input["format"] == ("iges" if ext == ".igs" else "step")
    assert r.signature["I_D"] == pytest.approx(WIGLEY_REFERENCE["I_D"], rel=2e-9)


def test_i_d_stability_rule_on_the_refinement_sequence():
    """Section 5.2: I_D is retained only when its last and prior relative changes over the
    refinement levels are within 2 % and 3 %; otherwise it is UNCONVERGED (value null)."""
    from hullprod_wb.brep.validity.metric_rules import _stable
    assert _stable([{"I_D": 1.0}, {"I_D": 1.029}, {"I_D": 1.04}])  # 2.9 % then 1.1 %
    assert not _stable([{"I_D": 1.0}, {"I_D": 1.05}, {"I_D": 1.051}])  # prior change 5 %
    assert not _stable([{"I_D": 1.0}, {"I_D": 1.0}, {"I_D": 1.03}])  # last change 2.9 %
    r = assess(half_wigley_shape(), lref=1.0)
    seq = r.validity["I_D"].evidence["refinement_sequence"]
    assert [h["depth"] for h in seq] == list(range(len(seq)))
    assert r.validity["I_D"].status.value == "VALID"


def test_unstable_refinement_sequence_makes_i_d_unconverged(monkeypatch):
    import hullprod_wb.brep.backend as backend
    fake = [{"depth": 0, "I_D": 1.0, "I_D_plus": 0.5, "I_D_minus": 0.5},
            {"depth": 1, "I_D": 2.0, "I_D_plus": 1.0, "I_D_minus": 1.0},
            {"depth": 2, "I_D": 4.0, "I_D_plus": 2.0, "I_D_minus": 2.0}]
    monkeypatch.setattr(backend, "refinement_history", lambda faces, lref: fake)
    r = assess(half_wigley_shape(), lref=1.0)
    v = r.validity["I_D"]
    assert v.status.value == "UNCONVERGED" and v.value is None
    assert v.evidence["refinement_sequence"] == fake
    assert r.validity["I_D_plus"].status.value == "VALID"  # the rule is I_D's


def test_timings_share_the_mesh_path_vocabulary():
    """Every stage's seconds under a key ending in _s, the whole run as total_s (as the mesh path)."""
    r = assess(plane_face(), lref=3.0)
    assert {"read_s", "quadrature_s", "total_s"} <= set(r.timings)
    assert all(k.endswith("_s") and v >= 0.0 for k, v in r.timings.items())
    assert r.timings["total_s"] >= r.timings["quadrature_s"]
