"""The point budget holds the lines of the last level's mixed cells too (brep.cubature
integrate with depth_limit and point_budget): a near-flat plate whose tiny K changes sign in
every cell is mixed everywhere, and its lines stop when the budget is spent, the values
staying within their error estimates."""
import math

import numpy as np
import pytest

from hullprod_wb.brep.cubature import integrate
from hullprod_wb.brep.geometry.trimmed_domain import TrimmedDomain

TAU_H, TAU_K = 1e-4, 1e-3
SQUARE = TrimmedDomain.rectangle(0.0, 1.0, 0.0, 1.0)
#: |K| of the plate, far below tau_K: the class is single curvature everywhere (H = 1)
AMPLITUDE = 1e-6 * TAU_K
#: sign changes of K across the square (whole periods in u and v)
NU, NV = 13, 11


def near_flat_plate(u, v):
    """J = 1, H = 1, K = AMPLITUDE sin(2 pi NU u) sin(2 pi NV v): the sign changes everywhere."""
    u, v = np.asarray(u, float), np.asarray(v, float)
    K = AMPLITUDE * np.sin(2 * math.pi * NU * u) * np.sin(2 * math.pi * NV * v)
    return {"J": np.ones_like(u), "K": K, "H": np.ones_like(u), "regular": np.ones(u.shape, bool)}


#: int |K| over the square: AMPLITUDE (2 / pi)^2 (the mean of |sin| over whole periods);
#: K+ and K- take half each
EXACT_ABS_K = AMPLITUDE * (2.0 / math.pi) ** 2


@pytest.mark.parametrize("budget", [50_000, 100_000])
def test_point_budget_bounds_the_lines_of_a_near_flat_plate(budget):
    r = integrate(SQUARE, near_flat_plate, TAU_H, TAU_K, rtol=1e-10, depth_limit=30, point_budget=budget)
    assert r.budget_spent and not r.converged["int_abs_K"]
    # the lines stop within one chunk of the budget (they took several times it before)
    assert r.n_points <= 1.25 * budget
    # what was computed stays within its own estimates
    assert abs(r.values["int_abs_K"] - EXACT_ABS_K) <= r.errors["int_abs_K"]
    for q in ("int_K_plus", "int_K_minus"):
        assert abs(r.values[q] - 0.5 * EXACT_ABS_K) <= r.errors[q]
    assert r.values["A_single"] == pytest.approx(1.0, abs=r.errors["A_single"] + 1e-12)
    assert r.values["A_flat"] + r.values["A_elliptic"] + r.values["A_saddle"] <= 1e-12


def test_plate_within_its_tolerance_is_unchanged_by_the_budget():
    # at rtol 1e-4 (and the zero floor of the K integrals) a generous budget converges it
    r = integrate(SQUARE, near_flat_plate, TAU_H, TAU_K, rtol=1e-4, depth_limit=30, point_budget=8_000_000)
    assert r.converged["int_abs_K"] and not r.budget_spent
    assert abs(r.values["int_abs_K"] - EXACT_ABS_K) <= r.tolerances["int_abs_K"]
    assert r.values["A_single"] == pytest.approx(1.0, abs=1e-10)


def test_lines_on_interpolants_take_one_pass_when_the_budget_does_not_bind(monkeypatch):
    # the last level's cells on their interpolants cost no field points: one pass, not chunks
    from hullprod_wb.brep.cubature import driver

    passes = []
    lines_of = driver.Integration._lines_of

    def counted(self, sub, *args, **kwargs):
        passes.append(sub.size)
        return lines_of(self, sub, *args, **kwargs)

    monkeypatch.setattr(driver.Integration, "_lines_of", counted)
    free = integrate(SQUARE, near_flat_plate, TAU_H, TAU_K, rtol=1e-4, depth_limit=30)
    n_free = len(passes)
    passes.clear()
    r = integrate(SQUARE, near_flat_plate, TAU_H, TAU_K, rtol=1e-4, depth_limit=30, point_budget=8_000_000)
    assert not r.budget_spent and r.n_points == free.n_points
    assert len(passes) == n_free
    assert r.values["int_abs_K"] == pytest.approx(free.values["int_abs_K"], rel=1e-12)


def test_lines_the_budget_left_whole_are_the_same_under_every_budget_they_need():
    # the last level's lines of the field go in chunks sized by the points left: a run whose
    # chunks the budget never cut is the same under every budget from its budget_needed on
    base = dict(rtol=1e-6, depth_limit=30)
    r = integrate(SQUARE, near_flat_plate, TAU_H, TAU_K, point_budget=8_000_000, **base)
    need = r.budget_needed
    assert need is not None and r.n_points <= need
    for budget in (need, 3 * need):
        s = integrate(SQUARE, near_flat_plate, TAU_H, TAU_K, point_budget=budget, **base)
        assert s.to_dict()["values"] == r.to_dict()["values"] and s.n_points == r.n_points
        assert s.errors == r.errors and s.budget_needed == need
    cut = integrate(SQUARE, near_flat_plate, TAU_H, TAU_K, point_budget=need - 1, **base)
    assert cut.budget_needed is None

