"""Progress reporting: a callable progress(fraction, message) and a stderr printer."""
import sys
import time


class Cancelled(Exception):
    """Raised inside a computation when the user asked to stop it."""


def null_progress(fraction, message=""):
    """A progress callback that reports nothing."""


def sub_progress(progress, lo, hi, prefix=""):
    """progress(fraction, message) of one part of a run: fraction in [0, 1] mapped onto
    [lo, hi] of progress, the message after prefix."""
    def sub(fraction, message=""):
        progress(lo + (hi - lo) * max(0.0, min(1.0, float(fraction))), prefix + str(message))
    return sub


class StderrProgress:
    """Prints at most every `interval` seconds: '[ 42%] message' on stderr."""

    def __init__(self, stream=None, interval=0.5):
        self.stream = stream or sys.stderr
        self.interval = interval
        self._last = 0.0

    def __call__(self, fraction, message=""):
        now = time.monotonic()
        if fraction < 1.0 and now - self._last < self.interval:
            return
        self._last = now
        self.stream.write("[%3d%%] %s\n" % (int(round(100 * max(0.0, min(1.0, fraction)))), message))
        self.stream.flush()
