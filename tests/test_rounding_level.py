"""Values at or below rounding are reported as 0, with their bound in the evidence."""
import numpy as np

from conftest import needs_freecad, shared_hull
from hullprod_wb.core.integrals import SurfaceIntegrals
from hullprod_wb.core.signature import rounding_bound, signature_values


def test_a_k_integral_at_rounding_level_is_zero():
    """A saddle-only surface whose int K+ dA is rounding noise (1e-49) has I_D+ = 0, while
    I_D and I_D- keep their values."""
    ig = SurfaceIntegrals(2.0, 2.0, 0.5, 1.5e-49, 0.5, np.array([1.0, 0.0, 0.0, 1.0]))
    v = signature_values(ig, 3.0)
    assert v["I_D_plus"] == 0.0
    assert v["I_D"] == v["I_D_minus"] == 9.0 * 0.5 / 2.0


def test_a_small_value_above_rounding_is_kept():
    """A numerically flat plate (I_D about 1e-9) is far above rounding: its value stays."""
    ig = SurfaceIntegrals(1.0, 1.0, 1e-9, 1e-9, 0.0, np.array([1.0, 0.0, 0.0, 0.0]))
    v = signature_values(ig, 1.0)
    assert v["I_D"] == v["I_D_plus"] == 1e-9
    assert rounding_bound(v["I_D"]) < 1e-12


def test_flat_face_reports_zero_not_rounding_noise():
    """A plane's integrals of rounding-sized K give I_D = 0 (not 1e-54)."""
    ig = SurfaceIntegrals(4.0, 4.0, 3e-54, 2e-54, 1e-54, np.array([4.0, 0.0, 0.0, 0.0]))
    v = signature_values(ig, 10.0)
    assert (v["I_D"], v["I_D_plus"], v["I_D_minus"]) == (0.0, 0.0, 0.0)


@needs_freecad
def test_wigley_i_d_plus_is_zero_with_its_bound_in_the_evidence():
    """The Wigley hull is saddle-shaped only: I_D+ is 0 and VALID, its evidence holds the
    bound and the integral it was set to 0 from (rounding noise, or exactly 0 where every
    sample's K is <= 0); its flat plates read 0."""
    from hullprod_wb.api import assess
    r = assess(shared_hull("brep/wigley_full_freecadship.brep"), with_fields=False)
    doc = r.to_dict()
    rec = doc["validity"]["I_D_plus"]
    assert rec["value"] == 0.0 and rec["status"] == "VALID"
    ev = rec["evidence"]
    assert ev["numerator"] >= 0.0
    assert ev["at_rounding"] is (ev["numerator"] > 0.0)
    assert 0.0 < ev["rounding_bound"] < 1e-11
    assert doc["validity"]["I_D"]["evidence"]["at_rounding"] is False
    faces = doc["provenance"]["faces"]
    assert all(f["I_D"] == 0.0 or f["I_D"] > f["rounding_bound"] for f in faces)
    assert any(f["I_D"] == 0.0 for f in faces)
