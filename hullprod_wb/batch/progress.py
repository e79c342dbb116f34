"""Batch progress on stderr: a bar with counts, rate (cases per minute) and ETA.

On a terminal the bar is redrawn in place; otherwise one line is printed per finished
case at most every `interval` seconds (and always for the last case and for failures).
"""
import sys
import time


def _clock(seconds):
    seconds = int(round(seconds))
    h, rem = divmod(seconds, 3600)
    m, s = divmod(rem, 60)
    return "%d:%02d:%02d" % (h, m, s) if h else "%d:%02d" % (m, s)


class BatchProgress:
    """progress.update(record) after each finished case; progress.close() at the end.

    total: cases to evaluate in this run; skipped: cases already done (shown, not timed).
    Rate and ETA count only the cases evaluated in this run.
    """

    def __init__(self, total, skipped=0, stream=None, enabled=True, width=24, interval=2.0):
        self.total = total
        self.skipped = skipped
        self.stream = stream or sys.stderr
        self.enabled = enabled
        self.width = width
        self.interval = interval
        self.done = 0
        self.failed = 0
        self.t0 = time.monotonic()
        self._last = -1e9
        self._tty = bool(getattr(self.stream, "isatty", lambda: False)())
        if enabled and skipped:
            self.stream.write("hullprod batch: %d case(s) already done with the same input and settings: skipped\n"
                              % skipped)
            self.stream.flush()

    def line(self, last=""):
        """The progress text: bar, n/total, failures, rate, elapsed and ETA."""
        frac = self.done / self.total if self.total else 1.0
        fill = int(round(self.width * frac))
        elapsed = time.monotonic() - self.t0
        rate = self.done / elapsed if elapsed > 0 and self.done else 0.0
        eta = (self.total - self.done) / rate if rate > 0 else None
        text = "[%s%s] %d/%d cases" % ("#" * fill, "." * (self.width - fill), self.done, self.total)
        if self.failed:
            text += ", %d failed" % self.failed
        text += "  %.1f cases/min  elapsed %s  ETA %s" % (60.0 * rate, _clock(elapsed),
                                                           "--:--" if eta is None else _clock(eta))
        return text + ("  " + last if last else "")

    def update(self, record):
        self.done += 1
        ok = record.get("status") == "ok"
        self.failed += 0 if ok else 1
        if not self.enabled:
            return
        cid = record["case"]["case_id"]
        if not ok:
            msg = "failed: %s: %s" % (cid, record["row"].get("error"))
            self.stream.write(("\r\033[K" if self._tty else "") + "hullprod batch: " + msg + "\n")
        now = time.monotonic()
        if self._tty:
            self.stream.write("\r\033[K" + self.line(cid))
        elif self.done == self.total or now - self._last >= self.interval:
            self.stream.write(self.line(cid) + "\n")
            self._last = now
        self.stream.flush()

    def close(self):
        if self.enabled and self._tty:
            self.stream.write("\n")
            self.stream.flush()
