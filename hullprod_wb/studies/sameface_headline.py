"""Which face a hull's same-face figure is quoted for (paper section 5.2, Table
tab:same_face_verification).

The paper samples "an unchanged authoritative BRep face" per hull without naming it. The
study quotes the face of largest area (the main hull face; on DTMB 5415 the paper's row fits
it, not the sonar dome) as ``headline_face``; a face whose curvature reference is quasi-zero
at the finest level (a flat plate, a deck) has no relative error to quote, so the headline
is the largest face that has one, and the larger faces passed over are listed with their
reasons. ``largest_K_face`` names the face carrying the largest share of the hull's
integral of |K| dA, with its own figures. Every face stays in the study's table.
"""


def face_shares(faces, abs_K_share=None):
    """Set abs_K_share and area_share on the face records (in place).

    abs_K_share: {face: share} from a BRep assessment; None: the faces' midpoint estimates
    abs_K_integral over their sum. A share that cannot be given is null with its reason.
    """
    total_area = sum(f.get("area") or 0.0 for f in faces)
    est = {f["face"]: f.get("abs_K_integral") for f in faces}
    total = sum(v for v in est.values() if v is not None)
    for f in faces:
        f.setdefault("reasons", {})
        f["area_share"] = f["area"] / total_area if (f.get("area") is not None and total_area > 0) else None
        if f["area_share"] is None:
            f["reasons"]["area_share"] = (f["reasons"].get("area") or "the faces have zero total area")
        if abs_K_share is not None:
            f["abs_K_share"] = abs_K_share.get(f["face"])
            f["abs_K_share_source"] = "BRep assessment (integral of |K| dA per face)"
            if f["abs_K_share"] is None:
                f["reasons"]["abs_K_share"] = "the BRep assessment gives no |K| share for this face"
        else:
            v = est.get(f["face"])
            f["abs_K_share"] = v / total if (v is not None and total > 0) else None
            f["abs_K_share_source"] = "midpoint estimate on the trimmed-domain raster"
            if f["abs_K_share"] is None:
                f["reasons"]["abs_K_share"] = (f.get("reasons", {}).get("abs_K_integral")
                                               or "the hull's integral of |K| is zero")
        if not f["reasons"]:
            del f["reasons"]


def _finest(face):
    recs = [r for r in face.get("levels", []) if not r.get("unavailable")]
    if not recs:
        return []
    n = max(r["panels"] for r in recs)
    return [r for r in recs if r["panels"] == n]


def figures(face):
    """{face, area, area_share, abs_K_share, panels, eps_H {pattern}, eps_K {pattern},
    diagnosis, reasons} of a face record at its finest compared level."""
    out = {"face": face["face"], "area": face.get("area"), "area_share": face.get("area_share"),
           "abs_K_share": face.get("abs_K_share"), "reasons": {}}
    for k in ("area_share", "abs_K_share"):
        if out[k] is None:
            out["reasons"][k] = face.get("reasons", {}).get(k, "not measured")
    recs = _finest(face)
    if not recs:
        why = face.get("skipped") or "no level compared"
        out.update(panels=None, eps_H=None, eps_K=None, diagnosis=None)
        out["reasons"].update(dict.fromkeys(("panels", "eps_H", "eps_K", "diagnosis"), why))
        return out
    out["panels"] = recs[0]["panels"]
    for q in ("eps_H", "eps_K"):
        out[q] = {r["pattern"]: r[q] for r in recs}
        why = {r["pattern"]: r["reasons"][q] for r in recs if r[q] is None}
        if why:
            out[q]["reasons"] = why
    out["diagnosis"] = face["diagnosis"]["text"]
    if not out["reasons"]:
        del out["reasons"]
    return out


def _has_figure(face):
    return any(r["eps_H"] is not None or r["eps_K"] is not None for r in _finest(face))


def headline_face(faces, selected=False):
    """The headline record (module docstring); None with a reason when no face has a figure."""
    rule = "largest area of the %s" % ("selected faces" if selected else "faces")
    by_area = sorted(faces, key=lambda f: -(f.get("area") or 0.0))
    passed = []
    for f in by_area:
        if _has_figure(f):
            out = figures(f)
            out["rule"] = rule if not passed else rule + " with a curvature reference"
            out["passed_over"] = passed
            return out
        recs = _finest(f)
        why = f.get("skipped") or "; ".join(sorted({r["reasons"][q] for r in recs for q in ("eps_H", "eps_K")
                                                    if r[q] is None})) or "no level compared"
        passed.append({"face": f["face"], "area": f.get("area"), "reason": why})
    return {"face": None, "rule": rule, "passed_over": passed,
            "reasons": {"face": "no face has a same-face error to quote"}}


def largest_K_face(faces):
    """Figures of the face with the largest abs_K_share; None with a reason when no share."""
    shared = [f for f in faces if f.get("abs_K_share") is not None]
    if not shared:
        return {"face": None, "reasons": {"face": "no face has a share of the integral of |K|"}}
    out = figures(max(shared, key=lambda f: f["abs_K_share"]))
    out["abs_K_share_source"] = shared[0].get("abs_K_share_source")
    return out
