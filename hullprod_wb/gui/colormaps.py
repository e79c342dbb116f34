"""Colour maps of the analysis display (presentation only, numpy).

Developability density: |K| L_ref^2 on a sequential map. Its display range is a Scale:
by default logarithmic between two percentiles of the samples above k_f (a robust range:
the paper's convention takes log10 k_f and the 99.5th percentile), or a fixed range (the
presets), linear or logarithmic; values outside are saturated in the display only.
Signed: K L_ref^2 on a diverging map (saddle blue, |K L_ref^2| <= k_f white, elliptic
red) with the same magnitude scale. Classes: one colour per curvature class, the legend
in shares of area. Plates (BRep): each face coloured by its own face-level I_D, a zero
included. Change (BRep): each face by the change of its share of I_D against the result
before, on the diverging map (no change white). Invalid samples (and faces without an established value) are mauve, a colour
no map uses, so that shading never makes a flat or zero colour read as invalid.
"""
from dataclasses import dataclass, field

import numpy as np

MAPS = ("Developability", "Classes", "Signed", "Plates", "Change")

#: Colour of invalid samples (outside the valid K domain): a mauve that no map uses and
#: that stays a hue, not a grey, under shading.
INVALID_RGB = (0.62, 0.30, 0.62)
#: Curvature class colours, eq:curvature_classes order (invalid first); flat is a sand
#: colour (a cream would shade to the grey of a dull surface).
CLASS_RGB = {"invalid": INVALID_RGB, "flat": (0.97, 0.86, 0.52), "single": (0.36, 0.72, 0.38),
             "elliptic": (0.86, 0.26, 0.20), "saddle": (0.20, 0.42, 0.86)}
CLASS_ORDER = ("invalid", "flat", "single", "elliptic", "saddle")

#: Sequential map anchors (position, r, g, b): dark blue -> teal -> yellow -> dark red.
SEQUENTIAL = np.array([[0.00, 0.18, 0.10, 0.45], [0.25, 0.13, 0.45, 0.70], [0.50, 0.20, 0.72, 0.55],
                       [0.75, 0.96, 0.84, 0.20], [1.00, 0.70, 0.08, 0.08]])
#: Diverging map anchors: saddle blue -> white -> elliptic red.
DIVERGING = np.array([[0.00, 0.12, 0.25, 0.70], [0.25, 0.45, 0.62, 0.92], [0.50, 0.97, 0.97, 0.97],
                      [0.75, 0.95, 0.55, 0.45], [1.00, 0.70, 0.08, 0.08]])

#: Percentiles of the samples above k_f that bound the default (percentile) scale.
LOW_PERCENTILE, HIGH_PERCENTILE = 10.0, 99.5
#: Scale kinds of the view (ScaleRange): two percentiles, the paper's [k_f, P99.5], a fixed range.
SCALE_RANGES = ("Percentile", "From k_f", "Fixed")
SCALE_TYPES = ("Logarithmic", "Linear")
#: Fixed ranges offered with one click (name, low, high) of |K| L_ref^2.
SCALE_PRESETS = (("0.01 to 100", 1e-2, 1e2), ("1 to 10 000", 1.0, 1e4), ("0.1 to 1000", 0.1, 1e3))


@dataclass
class Scale:
    """How values map to the colour ramp: range ('Percentile' | 'From k_f' | 'Fixed'),
    kind ('Logarithmic' | 'Linear'), low/high of a fixed range, and the percentiles."""

    range: str = "Percentile"
    kind: str = "Logarithmic"
    low: float = 1e-2
    high: float = 1e2
    low_percentile: float = LOW_PERCENTILE
    high_percentile: float = HIGH_PERCENTILE


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


def value_range(q, k_f, scale=None):
    """(lo, hi) of the values q (>= 0) shown by the ramp under scale (default Scale())."""
    scale = scale or Scale()
    q = np.asarray(q, float)
    pos = q[np.isfinite(q) & (q > k_f)]
    if scale.range == "Fixed":
        lo, hi = float(scale.low), float(scale.high)
    elif len(pos) == 0:
        lo, hi = float(k_f), 10.0 * k_f
    elif scale.range == "From k_f":
        lo, hi = float(k_f), float(np.percentile(pos, HIGH_PERCENTILE))
    else:
        lo, hi = (float(v) for v in np.percentile(pos, [scale.low_percentile, scale.high_percentile]))
    if scale.kind == "Linear" and scale.range != "Fixed":
        lo = 0.0
    if scale.kind == "Logarithmic":
        lo = max(lo, 1e-300)
        hi = max(hi, 10.0 * lo) if hi < 10.0 * lo and scale.range != "Fixed" else hi
    if not hi > lo:
        hi = lo + (1.0 if scale.kind == "Linear" else 10.0 * lo)
    return lo, hi


def scaled(q, lo, hi, kind):
    """q mapped to [0, 1] (saturated) by the scale kind; NaN stays NaN."""
    q = np.asarray(q, float)
    with np.errstate(divide="ignore", invalid="ignore"):
        if kind == "Linear":
            t = (q - lo) / (hi - lo)
        else:
            t = (np.log10(np.maximum(q, lo)) - np.log10(lo)) / (np.log10(hi) - np.log10(lo))
    return np.where(np.isfinite(q), np.clip(t, 0.0, 1.0), np.nan)


def _fmt(v):
    """Tick text of a value (3 significant digits)."""
    return "%.3g" % v if v == 0 or 1e-3 <= abs(v) < 1e5 else "%.2e" % v


def _ticks(lo, hi, kind, n=5, fmt=_fmt):
    s = np.linspace(0.0, 1.0, n)
    vals = lo + s * (hi - lo) if kind == "Linear" else 10.0 ** (np.log10(lo) + s * (np.log10(hi) - np.log10(lo)))
    return [(float(a), fmt(v)) for a, v in zip(s, vals)]


def _scale_text(scale, lo, hi):
    where = {"Percentile": "percentiles %g-%g of the samples above k_f" % (scale.low_percentile,
                                                                        scale.high_percentile),
             "From k_f": "k_f to the 99.5th percentile", "Fixed": "fixed range"}[scale.range]
    return "%s scale %s to %s (%s); saturated outside" % (scale.kind.lower(), _fmt(lo), _fmt(hi), where)


def developability_colors(q_D, k_f, scale=None):
    """Colours of q_D = |K| L_ref^2 (eq:devfield) under scale, and the legend."""
    scale = scale or Scale()
    q = np.asarray(q_D, float)
    lo, hi = value_range(q, k_f, scale)
    t = scaled(q, lo, hi, scale.kind)
    n_bad = int(np.sum(~np.isfinite(q)))
    title = "|K| L_ref^2 (%s)" % ("log scale" if scale.kind == "Logarithmic" else "linear scale")
    return ramp(t), Legend(title, "gradient", SEQUENTIAL, _ticks(lo, hi, scale.kind),
                           note="dimensionless; %s; mauve: invalid (%d samples)" % (_scale_text(scale, lo, hi), n_bad))


def signed_colors(K, valid, lref, k_f, scale=None):
    """Colours of K L_ref^2 on a diverging map of its magnitude under scale
    (eq:devsignedfields); |K L_ref^2| <= k_f is white."""
    scale = scale or Scale()
    q = np.where(np.asarray(valid, bool), np.asarray(K, float) * lref ** 2, np.nan)
    lo, hi = value_range(np.abs(q), k_f, scale)
    mag = scaled(np.abs(q), lo, hi, scale.kind)
    mag = np.where(np.abs(q) <= k_f, 0.0, mag)
    t = np.where(np.isfinite(q), 0.5 + 0.5 * np.sign(q) * mag, np.nan)
    mid = _ticks(lo, hi, scale.kind, 3)[1][1]
    ticks = [(0.0, "-" + _fmt(hi)), (0.25, "-" + mid), (0.5, "0 (|.|<=k_f)"), (0.75, "+" + mid), (1.0, "+" + _fmt(hi))]
    return ramp(t, DIVERGING), Legend("K L_ref^2: saddle (-) / elliptic (+)", "gradient", DIVERGING, ticks,
                                      note="magnitude on a %s; mauve: invalid" % _scale_text(scale, lo, hi))


def class_colors(class_id, shares=None):
    """Colours of the curvature class field c(x) (-1 invalid .. 3 saddle) and the legend.

    shares: class name -> share of the area (the assessment's a_C and the invalid share);
    the legend shows them in per cent (without: the shares of the display samples).
    """
    c = np.asarray(class_id, np.int64)
    table = np.array([CLASS_RGB[n] for n in CLASS_ORDER])
    cols = table[np.clip(c + 1, 0, len(CLASS_ORDER) - 1)]
    if shares is None:
        counts = np.bincount(np.clip(c + 1, 0, 4), minlength=5)
        shares = {n: counts[i] / max(1, counts.sum()) for i, n in enumerate(CLASS_ORDER)}
        note = "shares of the display samples"
    else:
        note = "shares of the area (a_C of the assessment; invalid: of the represented area)"
    entries = [(CLASS_RGB[n], "%s %s" % (n, _percent(shares.get(n)))) for n in CLASS_ORDER]
    return cols, Legend("curvature class (area)", "categorical", entries=entries,
                        note=note + "; thresholds tau_H, tau_K")


def _percent(x):
    return "n/a" if x is None or not np.isfinite(x) else "%.1f %%" % (100.0 * x)


def plate_colors(face_id, face_values, k_f):
    """Colours of the per-face I_D: face_id (n,) 1-based; face_values {face: I_D or None}.

    Logarithmic from the smallest established I_D above k_f to the largest; a face whose
    established I_D is at most k_f (flat to the class threshold, eq:class_thresholds, or 0)
    takes the bottom colour, marked on the legend; a face without an established I_D is
    mauve (not established).
    """
    fid = np.asarray(face_id, np.int64)
    top = int(max(fid.max(initial=0), max(face_values, default=0))) + 1
    lut = np.full(top, np.nan)
    for f, v in face_values.items():
        if v is not None and np.isfinite(v) and v >= 0:
            lut[int(f)] = v
    known = np.isfinite(lut)
    pos = lut[known & (lut > k_f)]
    lo, hi = (float(pos.min()), float(pos.max())) if len(pos) else (k_f, 10.0 * k_f)
    if hi <= lo * 1.000001:  # one value: a decade around it
        lo, hi = lo / 3.0, hi * 3.0
    has_low = bool(np.any(lut[known] <= k_f))
    vals = lut[np.clip(fid, 0, top - 1)]
    t = scaled(np.where(vals <= k_f, lo, vals), lo, hi, "Logarithmic")
    ticks = _ticks(lo, hi, "Logarithmic", fmt=lambda v: "%.4g" % v)
    if has_low:
        ticks[0] = (0.0, "<= k_f / %s" % ticks[0][1])
    return ramp(t), Legend("face I_D (plate view, log scale)", "gradient", SEQUENTIAL, ticks,
                           note="each face coloured by its own I_D%s; mauve: not established"
                                % ("; bottom colour: I_D <= k_f = %g (flat, or 0)" % k_f if has_low else ""))


def change_colors(face_id, changes):
    """Colours of each face's change of its share of I_D (its I_D times its area share)
    against the result before: face_id (n,) 1-based; changes {face: change or None (not in
    both results)}; linear on the diverging map, symmetric about 0 (white), to the largest
    change; mauve: not in both. Without changes (no result before) every face is white."""
    fid = np.asarray(face_id, np.int64)
    top = int(max(fid.max(initial=0), max(changes, default=0))) + 1
    lut = np.full(top, np.nan)
    for f, v in changes.items():
        if v is not None and np.isfinite(v):
            lut[int(f)] = v
    big = float(np.nanmax(np.abs(lut))) if np.isfinite(lut).any() else 0.0
    vals = lut[np.clip(fid, 0, top - 1)]
    t = 0.5 + 0.5 * vals / big if big > 0 else np.where(np.isfinite(vals), 0.5, np.nan)
    if not changes:
        return ramp(np.full(len(fid), 0.5), DIVERGING), Legend(
            "change of each face's share of I_D", "gradient", DIVERGING, [(0.5, "no result before")],
            note="a second run (an edit of the source) shows what changed")
    ticks = [(0.0, "-" + _fmt(big)), (0.5, "0"), (1.0, "+" + _fmt(big))] if big > 0 else [(0.5, "0: nothing changed")]
    return ramp(t, DIVERGING), Legend("change of each face's share of I_D", "gradient", DIVERGING, ticks,
                                      note="against the result before (faces by number); mauve: a face "
                                           "not in both results")


def distinct_colors(rgb, decimals=3):
    """Number of distinct colours in (n, 3) RGB."""
    return len(np.unique(np.round(np.asarray(rgb, float), decimals), axis=0))
