"""Progress of a running analysis in FreeCAD's progress indicator, with cancellation.

Backends call progress(fraction, message); raising core.progress.Cancelled from it stops
the run. In the GUI, FreeCAD's status-bar indicator lets the user press Esc to abort.
"""
from ..core.progress import Cancelled

#: Steps of FreeCAD's indicator for a whole run (a fraction maps to a step).
STEPS = 100


class RunProgress:
    """progress(fraction, message) callable for one run.

    label: text shown in FreeCAD's indicator; listener: optional callable(fraction,
    message) (a task panel's bar); use_indicator: drive FreeCAD.Base.ProgressIndicator
    (default: only when the GUI is up). cancel() makes the next call raise Cancelled.
    """

    def __init__(self, label="HullProd analysis", listener=None, use_indicator=None):
        self.label = label
        self.listener = listener
        self.cancelled = False
        self.last_message = ""
        self._indicator = None
        self._step = 0
        if use_indicator is None:
            try:
                import FreeCAD
                use_indicator = bool(FreeCAD.GuiUp)
            except ImportError:
                use_indicator = False
        self.use_indicator = use_indicator

    def cancel(self):
        self.cancelled = True

    def start(self):
        if self.use_indicator and self._indicator is None:
            import FreeCAD
            if hasattr(FreeCAD.Base, "ProgressIndicator"):
                self._indicator = FreeCAD.Base.ProgressIndicator()
                self._indicator.start(self.label, STEPS)
                self._step = 0

    def stop(self):
        if self._indicator is not None:
            try:
                self._indicator.stop()
            finally:
                self._indicator = None

    def __call__(self, fraction, message=""):
        self.last_message = message
        if self.listener is not None:
            self.listener(fraction, message)
        if self.cancelled:
            raise Cancelled("cancelled by the user during: %s" % (message or self.label))
        if self.use_indicator:
            self.start()
            target = int(max(0.0, min(1.0, float(fraction))) * STEPS)
            try:
                while self._step < target:
                    self._step += 1
                    self._indicator.next(True)  # True: Esc in the GUI aborts
            except RuntimeError as exc:  # FreeCAD raises it when the user aborted
                self._indicator = None
                self.cancelled = True
                raise Cancelled("cancelled by the user (Esc) during: %s" % (message or self.label)) from exc
