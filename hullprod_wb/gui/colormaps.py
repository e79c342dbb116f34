"""Colour maps of the analysis display (presentation only, numpy).

Developability density: log10(|K| L_ref^2) on a sequential map, display range
[log10 k_f, 99.5th percentile of the positive samples] (the paper's robust display range
convention); values outside are saturated in the display only, invalid samples are grey.
Signed: K L_ref^2 on a diverging map (saddle blue, |K L_ref^2| <= k_f white, elliptic
red) with the same logarithmic magnitude range. Classes: one colour per curvature class.
Plates (BRep): each face coloured by its own face-level I_D.
"""
from dataclasses import dataclass, field

import numpy as np

MAPS = ("Developability", "Classes", "Signed", "Plates")

#: Grey of invalid samples (outside the valid K domain).
INVALID_RGB = (0.55, 0.55, 0.55)
#: Curvature class colours, eq:curvature_classes order (invalid first).
CLASS_RGB = {"invalid": INVALID_RGB, "flat": (0.93, 0.93, 0.86), "single": (0.36, 0.72, 0.38),
             "elliptic": (0.86, 0.26, 0.20), "saddle": (0.20, 0.42, 0.86)}
CLASS_ORDER = ("invalid", "flat", "single", "elliptic", "saddle")

#: Sequential map anchors (position, r, g, b): dark blue -> teal -> yellow -> dark red.
SEQUENTIAL = np.array([[0.00, 0.18, 0.10, 0.45], [0.25, 0.13, 0.45, 0.70], [0.50, 0.20, 0.72, 0.55],
                       [0.75, 0.96, 0.84, 0.20], [1.00, 0.70, 0.08, 0.08]])
#: Diverging map anchors: saddle blue -> white -> elliptic red.
DIVERGING = np.array([[0.00, 0.12, 0.25, 0.70], [0.25, 0.45, 0.62, 0.92], [0.50, 0.97, 0.97, 0.97],
                      [0.75, 0.95, 0.55, 0.45], [1.00, 0.70, 0.08, 0.08]])

#: Percentile of the positive samples used as the upper display limit.
UPPER_PERCENTILE = 99.5


@dataclass
class Legend:
    """What a colour bar shows: title, kind ('gradient' | 'categorical'), for a gradient
    the anchor table and tick (position in [0, 1], text) pairs, for categories
    (rgb, text) entries; note: a line on clipping and invalid samples."""

    title: str
    kind: str
    anchors: object = None
    ticks: list = field(default_factory=list)
    entries: list = field(default_factory=list)
    note: str = ""


def ramp(t, anchors=SEQUENTIAL):
    """(n,) values in [0, 1] -> (n, 3) RGB by piecewise-linear anchors; NaN -> grey."""
    t = np.asarray(t, float)
    out = np.empty(t.shape + (3,))
    tt = np.clip(np.nan_to_num(t, nan=0.0), 0.0, 1.0)
    for c in range(3):
        out[..., c] = np.interp(tt, anchors[:, 0], anchors[:, c + 1])
    out[np.isnan(t)] = INVALID_RGB
    return out


def log_range(q, k_f):
    """(lo, hi) of log10 q for display: lo = log10 k_f, hi = 99.5th percentile of q > k_f."""
    q = np.asarray(q, float)
    lo = float(np.log10(k_f))
    pos = q[np.isfinite(q) & (q > k_f)]
    hi = float(np.percentile(np.log10(pos), UPPER_PERCENTILE)) if len(pos) else lo + 1.0
    return lo, max(hi, lo + 1.0)


def _fmt_pow(x):
    """Tick text of the value 10**x (a plain number, 3 significant digits)."""
    v = 10.0 ** x
    return "%.3g" % v if 1e-3 <= v < 1e5 else "%.2e" % v


def developability_colors(q_D, k_f):
    """Colours of log10 q_D (q_D = |K| L_ref^2, eq:devfield) and the legend."""
    q = np.asarray(q_D, float)
    lo, hi = log_range(q, k_f)
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (np.log10(np.where(q > 0, q, 10.0 ** lo)) - lo) / (hi - lo)
    t = np.where(np.isfinite(q), t, np.nan)
    ticks = [(float(s), _fmt_pow(lo + s * (hi - lo))) for s in np.linspace(0, 1, 5)]
    n_bad = int(np.sum(~np.isfinite(q)))
    return ramp(t), Legend("|K| L_ref^2 (log scale)", "gradient", SEQUENTIAL, ticks,
                           note="dimensionless; saturated outside [%s, %s] in the display only; grey: "
                                "invalid (%d samples)" % (_fmt_pow(lo), _fmt_pow(hi), n_bad))


def signed_colors(K, valid, lref, k_f):
    """Colours of K L_ref^2 on a diverging log-magnitude map (eq:devsignedfields)."""
    q = np.where(np.asarray(valid, bool), np.asarray(K, float) * lref ** 2, np.nan)
    lo, hi = log_range(np.abs(q), k_f)
    with np.errstate(divide="ignore", invalid="ignore"):
        mag = np.clip((np.log10(np.abs(q)) - lo) / (hi - lo), 0.0, 1.0)
    mag = np.where(np.abs(q) <= k_f, 0.0, mag)
    t = np.where(np.isfinite(q), 0.5 + 0.5 * np.sign(q) * mag, np.nan)
    ticks = [(0.0, "-" + _fmt_pow(hi)), (0.25, "-" + _fmt_pow(0.5 * (lo + hi))), (0.5, "0 (|.|<=k_f)"),
             (0.75, "+" + _fmt_pow(0.5 * (lo + hi))), (1.0, "+" + _fmt_pow(hi))]
    return ramp(t, DIVERGING), Legend("K L_ref^2: saddle (-) / elliptic (+)", "gradient", DIVERGING, ticks,
                                      note="log magnitude; grey: invalid")


def class_colors(class_id):
    """Colours of the curvature class field c(x) (-1 invalid .. 3 saddle) and the legend."""
    c = np.asarray(class_id, np.int64)
    table = np.array([CLASS_RGB[n] for n in CLASS_ORDER])
    cols = table[np.clip(c + 1, 0, len(CLASS_ORDER) - 1)]
    counts = np.bincount(np.clip(c + 1, 0, 4), minlength=5)
    entries = [(CLASS_RGB[n], "%s (%d samples)" % (n, counts[i])) for i, n in enumerate(CLASS_ORDER)]
    return cols, Legend("curvature class", "categorical", entries=entries,
                        note="class of each display sample (thresholds tau_H, tau_K)")


def plate_colors(face_id, face_values):
    """Colours of the per-face I_D: face_id (n,) 1-based; face_values {face: I_D or None}.

    log10 I_D over the range of the faces; a face without an established I_D is grey.
    """
    fid = np.asarray(face_id, np.int64)
    top = int(max(fid.max(initial=0), max(face_values, default=0))) + 1
    lut = np.full(top, np.nan)
    for f, v in face_values.items():
        if v is not None and v > 0:
            lut[int(f)] = np.log10(v)
    fin = lut[np.isfinite(lut)]
    lo, hi = (float(fin.min()), float(fin.max())) if len(fin) else (0.0, 1.0)
    if hi - lo < 1e-6:
        lo, hi = lo - 0.5, hi + 0.5
    t = (lut[np.clip(fid, 0, top - 1)] - lo) / (hi - lo)
    ticks = [(float(s), "%.4g" % 10 ** (lo + s * (hi - lo))) for s in np.linspace(0, 1, 5)]
    return ramp(t), Legend("face I_D (plate view, log scale)", "gradient", SEQUENTIAL, ticks,
                           note="each face coloured by its own I_D; grey: not established")


def distinct_colors(rgb, decimals=3):
    """Number of distinct colours in (n, 3) RGB."""
    return len(np.unique(np.round(np.asarray(rgb, float), decimals), axis=0))
