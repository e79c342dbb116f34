"""Compare: two or more analyses side by side (table and bar chart), with the reasons a
comparison is not like for like (from hullprod_wb.app.compare)."""
import io

from ..app.compare import compare_analyses
from ..core.constants import METRIC_LABELS
from . import wording
from .qt import QtCore, QtGui, QtWidgets, CloseOnlyPanel

#: The compare panel shown last (scripts and tests read it).
LAST_PANEL = None


def chart_png(cmp, width_in=6.4, height_in=3.6, dpi=110):
    """PNG bytes of the grouped bar chart: I_D, I_D+, I_D- (left), class fractions (right).

    Metrics without an established value get no bar and an 'n/a' mark.
    """
    from matplotlib.figure import Figure
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    fig = Figure(figsize=(width_in, height_in), dpi=dpi)
    FigureCanvasAgg(fig)
    labels = cmp["labels"]
    groups = (("I_D", "I_D_plus", "I_D_minus"), ("a_flat", "a_single", "a_elliptic", "a_saddle"))
    titles = ("developability (dimensionless)", "curvature-class area fractions")
    n = len(labels)
    width = 0.8 / n
    for k, (metrics, title) in enumerate(zip(groups, titles)):
        ax = fig.add_subplot(1, 2, k + 1)
        for i, lab in enumerate(labels):
            xs = [j + (i - (n - 1) / 2.0) * width for j in range(len(metrics))]
            vals = [cmp["values"][m][i] for m in metrics]
            ax.bar([x for x, v in zip(xs, vals) if v is not None], [v for v in vals if v is not None],
                   width * 0.95, label=lab)
            for x, v in zip(xs, vals):
                if v is None:
                    ax.text(x, 0, "n/a", ha="center", va="bottom", fontsize=10, rotation=90)
        ax.set_xticks(range(len(metrics)))
        ax.set_xticklabels([METRIC_LABELS[m] for m in metrics], fontsize=11)
        ax.set_title(title, fontsize=11)
        ax.tick_params(labelsize=10)
        if k == 1:
            ax.set_ylim(0, 1)
    fig.axes[0].legend(fontsize=10)
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png")
    return buf.getvalue()


class ComparePanel(CloseOnlyPanel):
    """Task panel: the analyses to compare (every open document's, ticked ones compared),
    flags, table of values and statuses, bar chart."""

    def __init__(self, analyses, candidates=None):
        global LAST_PANEL
        LAST_PANEL = self
        self.candidates = list(candidates or analyses)
        chosen = {(a.Document.Name, a.Name) for a in analyses}
        self.form = QtWidgets.QWidget()
        self.form.setWindowTitle("HullProd compare")
        self.layout = QtWidgets.QVBoxLayout(self.form)
        self.choice = self._choice_list(chosen)
        self.layout.addWidget(self.choice)
        self.flags_label = QtWidgets.QLabel()
        self.flags_label.setWordWrap(True)
        self.layout.addWidget(self.flags_label)
        self.table = None
        self.chart = QtWidgets.QLabel()
        self.layout.addWidget(self.chart)
        self.refresh()
        self.choice.itemChanged.connect(lambda *args: self.refresh())

    def _choice_list(self, chosen):
        """One tickable row per analysis of the open documents, named with its document."""
        box = QtWidgets.QListWidget()
        for a, text in zip(self.candidates, ["%s: %s" % (a.Document.Label, a.Label) for a in self.candidates]):
            it = QtWidgets.QListWidgetItem(text)
            it.setFlags(it.flags() | QtCore.Qt.ItemIsUserCheckable)
            it.setCheckState(QtCore.Qt.Checked if (a.Document.Name, a.Name) in chosen else QtCore.Qt.Unchecked)
            box.addItem(it)
        box.setMaximumHeight(22 * min(len(self.candidates), 6) + 8)
        return box

    def ticked(self):
        """The analyses whose rows are ticked, in list order."""
        return [a for i, a in enumerate(self.candidates) if self.choice.item(i).checkState() == QtCore.Qt.Checked]

    def refresh(self):
        """Compare the ticked analyses: flags, table and chart (a note when fewer than two)."""
        self.analyses = self.ticked()
        if self.table is not None:
            self.layout.removeWidget(self.table)
            self.table.deleteLater()
            self.table = None
        self.png = None
        self.chart.clear()
        if len(self.analyses) < 2:
            self.cmp = None
            self.flags_label.setText("Tick two or more analyses to compare them.")
            return
        self.cmp = compare_analyses(self.analyses)
        if self.cmp["flags"]:
            text = ("<b style='color:#c0392b'>Not like for like:</b><ul>%s</ul>"
                    % "".join("<li>%s</li>" % f for f in self.cmp["flags"]))
        else:
            text = ("<b style='color:#2e8b57'>Like for like:</b> same representation, L_ref convention, "
                    "units and thresholds.")
        self.flags_label.setText(text)
        self.table = self._table()
        self.layout.insertWidget(self.layout.indexOf(self.chart), self.table)
        try:
            self.png = chart_png(self.cmp)
        except ImportError as exc:  # matplotlib is optional: the table still compares
            self.chart.setText("bar chart needs matplotlib (%s)" % exc)
        else:
            img = QtGui.QImage.fromData(self.png, "PNG")
            self.chart.setPixmap(QtGui.QPixmap.fromImage(img).scaledToWidth(460, QtCore.Qt.SmoothTransformation))

    def _table(self):
        cmp = self.cmp
        ctx_keys = list(cmp["context"][0])
        rows = [METRIC_LABELS[m] for m in cmp["metrics"]] + ctx_keys
        t = QtWidgets.QTableWidget(len(rows), len(cmp["labels"]))
        t.setHorizontalHeaderLabels(cmp["labels"])
        t.setVerticalHeaderLabels(rows)
        for j in range(len(cmp["labels"])):
            for i, m in enumerate(cmp["metrics"]):
                v, s = cmp["values"][m][j], cmp["statuses"][m][j]
                it = QtWidgets.QTableWidgetItem("%s  %s" % (wording.format_value(v), s))
                it.setForeground(QtGui.QBrush(QtGui.QColor(wording.status_color(s))))
                it.setToolTip(wording.status_sentence(s))
                t.setItem(i, j, it)
            for i, k in enumerate(ctx_keys):
                v = cmp["context"][j][k]
                t.setItem(len(cmp["metrics"]) + i, j, QtWidgets.QTableWidgetItem(
                    wording.format_value(v) if isinstance(v, float) else str(v)))
        t.resizeColumnsToContents()
        t.setMinimumHeight(26 * (len(rows) + 1))
        return t

    def save_chart(self, path):
        if self.png is None:
            return None
        with open(path, "wb") as fh:
            fh.write(self.png)
        return path


def show_compare_panel(analyses, candidates=None):
    """Open the compare panel on analyses; candidates: the analyses it lists (default: those)."""
    from .on_screen import show_task_panel
    return show_task_panel(ComparePanel(analyses, candidates))
