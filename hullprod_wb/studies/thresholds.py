"""Threshold study: the signature under several quasi-zero tolerances h_f = k_f
(paper section 6.2, default {1e-5, 1e-4, 1e-3}).

For each tolerance the hull is assessed (same backend, same L_ref) and reported: the four
class fractions and the total double-curved fraction a_elliptic + a_saddle. I_D, I_D+ and
I_D- do not depend on the tolerances by definition (eq:dev, eq:devsigned); their largest
relative spread over the tolerances, (max - min) / max |value|, is reported as the check.
"""
from ..core.constants import CLASS_NAMES
from ..core.errors import InputError
from ..core.progress import null_progress, sub_progress
from ..core.writers import json_safe
from .refinement import _signature_row

#: Default tolerances h_f = k_f of the study.
DEFAULT_TOLERANCES = (1e-5, 1e-4, 1e-3)


def relative_spread(values):
    """(max - min) / max |v| over the finite values, None when fewer than two or all zero."""
    vals = [float(v) for v in values if v is not None]
    if len(vals) < 2:
        return None
    scale = max(abs(v) for v in vals)
    return (max(vals) - min(vals)) / scale if scale > 0 else 0.0


def threshold_study(source, tolerances=DEFAULT_TOLERANCES, lref=None, backend=None, faces=None,
                    progress=None, **options):
    """Signature per tolerance h_f = k_f (see module docstring).

    source: any input of :func:`hullprod_wb.assess`; tolerances: dimensionless h_f = k_f
    values; lref: L_ref (None: automatic, fixed by the first assessment and reused);
    options: BRep quadrature options. Returns a JSON-safe dict: study, input, lref, rows
    (h_f, k_f, a_C, double_curved, I_D, I_D+, I_D-, statuses), I_D_spread,
    double_curved_change (smallest to largest tolerance: absolute and relative).
    """
    from ..api import assess
    progress = progress or null_progress
    tols = sorted(float(t) for t in tolerances)
    if not tols or min(tols) <= 0:
        raise InputError("threshold study: tolerances must be positive numbers, got %r" % (tolerances,))
    rows, first = [], None
    for k, t in enumerate(tols):
        a = assess(source, lref=lref, h_f=t, k_f=t, backend=backend, faces=faces, with_fields=False,
                   progress=sub_progress(progress, k / len(tols), (k + 1) / len(tols), "h_f = k_f = %g: " % t),
                   **options)
        if first is None:
            first = a
            lref = a.reference_length.value
        row = dict(_signature_row(a), h_f=t, k_f=t)
        e, s = row["a_C"].get("elliptic"), row["a_C"].get("saddle")
        row["double_curved"] = None if e is None or s is None else e + s
        rows.append(row)
    dc = [r["double_curved"] for r in rows]
    change = None
    if dc[0] is not None and dc[-1] is not None:
        change = {"from": tols[0], "to": tols[-1], "absolute": dc[-1] - dc[0],
                  "relative": (dc[-1] - dc[0]) / dc[0] if dc[0] else None}
    spread = {q: relative_spread([r[q] for r in rows]) for q in ("I_D", "I_D_plus", "I_D_minus")}
    class_range = {n: [min(r["a_C"][n] for r in rows if r["a_C"][n] is not None),
                       max(r["a_C"][n] for r in rows if r["a_C"][n] is not None)]
                   if all(r["a_C"][n] is not None for r in rows) else None for n in CLASS_NAMES}
    progress(1.0, "threshold study done")
    doc = {"study": "thresholds", "input": first.input, "representation": first.input.get("representation"),
           "lref": lref, "tolerances": tols, "rows": rows, "I_D_spread": spread,
           "max_I_D_spread": max((v for v in spread.values() if v is not None), default=None),
           "double_curved_change": change, "class_range": class_range}
    return json_safe(doc)
