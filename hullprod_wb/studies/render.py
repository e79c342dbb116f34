"""PNG maps of a hull's distributed fields (paper Figs. fig:developabilitydensity,
fig:classpanels) with matplotlib's Agg canvas (no GUI, no pyplot state).

Fixed orthographic views (world axes of the input; hulls: x longitudinal, z up):

* ``profile``: screen right = +x, screen up = +z, seen along the y axis from the side on
  which the surface lies (from -y when the surface extends further to -y than to +y, else
  from +y, so a half hull shows its outer side);
* ``bottom``: screen right = +x, screen up = +y, seen from below (from -z).

Triangles are painted far-to-near (painter's algorithm on the mean depth of their
vertices), each with one colour: the mean of its vertices' values, grey when any of its
vertices is an invalid sample.

Developability density: log10(|K| L_ref^2) on the display range [log10(k_f), the 99.5th
percentile of the positive valid samples] (the paper's convention); values outside the
range are saturated for display only. Curvature classes: flat, single, elliptic, saddle
and invalid (grey), each triangle coloured by the class most of its vertices carry.
"""
import io

import numpy as np

from ..core.constants import CLASS_NAMES, DEFAULT_KF

#: Colour of invalid samples.
INVALID_COLOUR = "#9e9e9e"
#: Class colours (flat, single, elliptic, saddle), colour-blind distinguishable.
CLASS_COLOURS = ("#e6d690", "#4daf4a", "#d7301f", "#2c7fb8")
#: Colour map of the developability density.
DENSITY_CMAP = "viridis"
#: Upper display limit: this percentile of the positive valid samples of log10(q_D).
UPPER_PERCENTILE = 99.5
#: View name -> (screen-right axis, screen-up axis, depth axis) as world axis indices.
VIEWS = {"profile": (0, 2, 1), "bottom": (0, 1, 2)}
VIEW_TITLES = {"profile": "profile (x right, z up, seen along y)",
               "bottom": "bottom (x right, y up, seen from below)"}


def _depth_sign(points, view):
    """+1 when the viewer sits at -infinity along the depth axis, else -1."""
    axis = VIEWS[view][2]
    if view == "bottom":
        return 1.0
    lo, hi = float(np.nanmin(points[:, axis])), float(np.nanmax(points[:, axis]))
    return 1.0 if abs(lo) > abs(hi) else -1.0


def projected_triangles(points, triangles, view):
    """(m, 3, 2) screen coordinates of the triangles and their far-to-near order (m,) int."""
    right, up, depth = VIEWS[view]
    P = np.asarray(points, dtype=float)
    T = np.asarray(triangles, dtype=np.int64)
    xy = P[:, [right, up]][T]
    d = _depth_sign(P, view) * P[:, depth][T].mean(axis=1)
    order = np.argsort(-d, kind="stable")  # largest distance from the viewer first
    return xy, order


def density_values(fields, k_f=DEFAULT_KF):
    """Per-sample log10(q_D) (n,) with NaN where invalid, and the display range (lo, hi)."""
    q = np.asarray(fields.q_D, dtype=float)
    valid = np.isfinite(q)
    with np.errstate(divide="ignore"):
        lg = np.where(valid, np.log10(np.where(q > 0, q, np.nan)), np.nan)
    lo = float(np.log10(k_f))
    lg = np.where(valid & ~np.isfinite(lg), lo, lg)  # q_D = 0 shows at the lower limit
    pos = lg[valid & (q > 0)]
    hi = float(np.percentile(pos, UPPER_PERCENTILE)) if pos.size else lo + 1.0
    if not hi > lo:
        hi = lo + 1.0
    return lg, (lo, hi)


def triangle_mean(values, triangles):
    """(m,) mean of per-vertex values over each triangle, NaN when any vertex is NaN."""
    return np.asarray(values, dtype=float)[np.asarray(triangles, dtype=np.int64)].mean(axis=1)


def triangle_class(class_id, triangles):
    """(m,) int class per triangle: the class two or three vertices share (else the first
    vertex's), -1 (invalid) when any vertex is invalid."""
    c = np.asarray(class_id, dtype=np.int64)[np.asarray(triangles, dtype=np.int64)]
    out = np.where(c[:, 1] == c[:, 2], c[:, 1], c[:, 0])
    return np.where((c < 0).any(axis=1), -1, out)


def _figure(n_views, width=10.0, height=None):
    from matplotlib.figure import Figure
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    fig = Figure(figsize=(width, height or 2.6 * n_views + 0.9), dpi=100)
    FigureCanvasAgg(fig)
    return fig


def _map_axes(points, views, width=10.0, legend_space=0.0):
    """Figure and one axes per view, axes heights following the views' aspect ratios."""
    P = np.asarray(points, dtype=float)
    ratios = []
    for view in views:
        right, up, _ = VIEWS[view]
        ext = np.nanmax(P[:, [right, up]], axis=0) - np.nanmin(P[:, [right, up]], axis=0)
        ratios.append(float(np.clip(ext[1] / max(ext[0], 1e-300), 0.08, 1.0)))
    plot_w = 0.72 * width
    height = float(np.clip(sum(plot_w * r + 0.6 for r in ratios) + 0.8 + legend_space, 3.0, 14.0))
    fig = _figure(len(views), width, height)
    axes = fig.subplots(len(views), 1, squeeze=False, gridspec_kw={"height_ratios": ratios, "hspace": 0.5})[:, 0]
    return fig, axes


def _png(fig):
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=100)
    return buf.getvalue()


def _draw(ax, xy, colours, order, view):
    from matplotlib.collections import PolyCollection
    pc = PolyCollection(xy[order], facecolors=colours[order], edgecolors=colours[order],
                        linewidths=0.25, antialiaseds=False)
    ax.add_collection(pc)
    lo = xy.reshape(-1, 2).min(axis=0)
    hi = xy.reshape(-1, 2).max(axis=0)
    pad = 0.02 * max(float(np.max(hi - lo)), 1e-300)
    ax.set_xlim(lo[0] - pad, hi[0] + pad)
    ax.set_ylim(lo[1] - pad, hi[1] + pad)
    ax.set_aspect("equal")
    ax.set_title(VIEW_TITLES[view], fontsize=9)
    ax.tick_params(labelsize=7)


def render_density_map(fields, k_f=DEFAULT_KF, title=None, views=("profile", "bottom")):
    """PNG bytes of the developability-density map log10(|K| L_ref^2) (see module docstring)."""
    from matplotlib import cm, colors
    lg, (lo, hi) = density_values(fields, k_f)
    norm = colors.Normalize(vmin=lo, vmax=hi, clip=True)
    import matplotlib
    cmap = matplotlib.colormaps[DENSITY_CMAP]
    tv = triangle_mean(lg, fields.triangles)
    rgba = cmap(norm(np.nan_to_num(tv, nan=lo)))
    rgba[~np.isfinite(tv)] = colors.to_rgba(INVALID_COLOUR)
    fig, axes = _map_axes(fields.points, views)
    for ax, view in zip(axes, views):
        xy, order = projected_triangles(fields.points, fields.triangles, view)
        _draw(ax, xy, rgba, order, view)
    sm = cm.ScalarMappable(norm=norm, cmap=cmap)
    cb = fig.colorbar(sm, ax=list(axes), shrink=0.9, pad=0.02)
    cb.set_label("log10(|K| L_ref^2)  (grey: invalid)", fontsize=8)
    cb.ax.tick_params(labelsize=7)
    fig.suptitle(title or "developability density, display range [%.3g, %.3g]" % (lo, hi), fontsize=10)
    return _png(fig)


def render_class_map(fields, title=None, views=("profile", "bottom"), fractions=None):
    """PNG bytes of the curvature-class map with its legend (see module docstring).

    fractions: optional (4,) class area fractions shown in the legend.
    """
    from matplotlib import colors
    from matplotlib.patches import Patch
    tc = triangle_class(fields.class_id, fields.triangles)
    palette = np.array([colors.to_rgba(c) for c in CLASS_COLOURS + (INVALID_COLOUR,)])
    rgba = palette[np.where(tc < 0, 4, tc)]
    fig, axes = _map_axes(fields.points, views, legend_space=0.5)
    for ax, view in zip(axes, views):
        xy, order = projected_triangles(fields.points, fields.triangles, view)
        _draw(ax, xy, rgba, order, view)
    labels = list(CLASS_NAMES)
    if fractions is not None:
        labels = ["%s %.4f" % (n, f) if f is not None else "%s -" % n for n, f in zip(CLASS_NAMES, fractions)]
    handles = [Patch(facecolor=c, edgecolor="k", linewidth=0.3, label=l)
               for c, l in zip(CLASS_COLOURS + (INVALID_COLOUR,), labels + ["invalid"])]
    fig.legend(handles=handles, loc="lower center", ncol=5, fontsize=8, frameon=False)
    fig.suptitle(title or "curvature classes", fontsize=10)
    fig.subplots_adjust(bottom=0.6 / fig.get_figheight() + 0.08)
    return _png(fig)


#: Faces drawn with a legend entry each in the same-face plot; with more faces only the
#: headline and largest-|K| faces are labelled and the others drawn thin and grey.
LABELLED_FACES = 6


def render_sameface_errors(study):
    """PNG bytes of eps_H and eps_K against panels (log-log), one line per face and pattern."""
    fig = _figure(1, width=9.0)
    axes = fig.subplots(1, 2)
    styles = {"consistent": "-o", "alternating": "--s"}
    faces = study.get("faces", [])
    named = {(study.get(k) or {}).get("face"): k for k in ("headline_face", "largest_K_face")}
    few = sum(1 for f in faces if f.get("levels")) <= LABELLED_FACES
    for face in faces:
        key = named.get(face["face"]) if face["face"] is not None else None
        for pattern, style in styles.items():
            recs = sorted((r for r in face.get("levels", []) if r["pattern"] == pattern),
                          key=lambda r: r["panels"])
            for ax, q in zip(axes, ("eps_H", "eps_K")):
                pts = [(r["panels"], r[q]) for r in recs if r[q] is not None and r[q] > 0]
                if not pts:
                    continue
                n, e = zip(*pts)
                if few or key:
                    tag = {"headline_face": " (headline)", "largest_K_face": " (largest |K|)"}.get(key, "")
                    ax.loglog(n, [100 * x for x in e], style, ms=3, lw=1,
                              label="face %s%s %s" % (face["face"], tag, pattern))
                else:
                    ax.loglog(n, [100 * x for x in e], "-", color="#bbbbbb", lw=0.5, zorder=0)
    for ax, q in zip(axes, ("H", "K")):
        ax.set_xlabel("panels per direction", fontsize=8)
        ax.set_ylabel("relative L2 error of %s [%%]" % q, fontsize=8)
        ax.set_title("same-face %s error (relative L2)" % q, fontsize=9)
        ax.tick_params(labelsize=7)
        ax.grid(True, which="both", lw=0.3)
    handles, labels = axes[0].get_legend_handles_labels()
    if handles:
        axes[1].legend(handles, labels, fontsize=6, loc="best")
    fig.tight_layout()
    return _png(fig)
