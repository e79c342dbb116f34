"""Signature as a function of design parameters, for optimisation loops.

SignatureObjective(make_hull, **options) maps a parameter vector x to the signature vector
I_sig(x) = [I_D, I_D+, I_D-, a_flat, a_single, a_elliptic, a_saddle] (paper eq:vector) as a
(7,) float array, NaN where a metric is not established. make_hull(x) returns anything
assess() accepts (a file path, Part.Shape, FreeCAD object, mesh). Repeated vectors are
answered from a cache, so an optimiser that evaluates objective and constraints at the same
x assesses the hull once.
"""
import collections

import numpy as np

from ..core.constants import METRICS
from ..core.errors import InputError


class MetricFunction:
    """x -> one signature entry (float), optionally scaled; `missing` replaces NaN."""

    def __init__(self, objective, name, scale=1.0, missing=np.nan):
        if name not in METRICS:
            raise InputError("unknown metric %r; known: %s" % (name, ", ".join(METRICS)))
        self.objective = objective
        self.index = METRICS.index(name)
        self.name = name
        self.scale = float(scale)
        self.missing = float(missing)

    def __call__(self, x):
        v = self.objective(x)[self.index]
        return self.scale * (self.missing if np.isnan(v) else float(v))


class SignatureObjective:
    """Callable x -> signature vector (7,) float with NaN where not established.

    make_hull: callable x -> assessable source. options: assess() settings (lref, h_f,
    k_f, backend, faces, order, rtol, max_depth, and backend keywords such as
    display_deflection). cache_size: vectors remembered (least
    recently used are forgotten). on_error: 'raise' re-raises a failure of make_hull or
    assess; 'nan' answers an all-NaN vector and keeps the message in .errors.
    Counters: calls (every call), evaluations (hulls actually assessed).
    Picklable when make_hull is (e.g. a top-level function or parametric.DocumentHull).
    """

    def __init__(self, make_hull, cache_size=1024, on_error="raise", **options):
        from .api import split_options
        if on_error not in ("raise", "nan"):
            raise InputError("on_error must be 'raise' or 'nan', got %r" % (on_error,))
        self.make_hull = make_hull
        self.settings = split_options(options)
        self.cache_size = int(cache_size)
        self.on_error = on_error
        self.calls = 0
        self.evaluations = 0
        self.errors = {}
        self._cache = collections.OrderedDict()

    @staticmethod
    def key(x):
        """Cache key of a parameter vector: its exact float values."""
        return tuple(float(v) for v in np.ravel(np.asarray(x, dtype=float)))

    def _assess(self, x):
        from ..api import assess
        from .worker import assess_options
        return assess(self.make_hull(np.asarray(x, dtype=float)), **assess_options(self.settings))

    def evaluate(self, x):
        """(vector (7,) float, Assessment or None) of x, from the cache when seen before."""
        self.calls += 1
        k = self.key(x)
        if k in self._cache:
            self._cache.move_to_end(k)
            vec, result = self._cache[k]
            return vec.copy(), result
        self.evaluations += 1
        try:
            result = self._assess(x)
            vec = np.array([np.nan if v is None else float(v) for v in result.vector], dtype=float)
        except Exception as exc:
            if self.on_error == "raise":
                raise
            self.errors[k] = "%s: %s" % (type(exc).__name__, " ".join(str(exc).split()))
            result, vec = None, np.full(len(METRICS), np.nan)
        self._cache[k] = (vec, result)
        while len(self._cache) > self.cache_size:
            self._cache.popitem(last=False)
        return vec.copy(), result

    def __call__(self, x):
        return self.evaluate(x)[0]

    def assessment(self, x):
        """The full Assessment of x (validity reasons, reference length, ...), or None on error."""
        return self.evaluate(x)[1]

    def metric(self, name, scale=1.0, missing=np.nan):
        """Scalar function x -> scale * metric; e.g. metric('I_D') to minimise I_D."""
        return MetricFunction(self, name, scale, missing)

    def constraint(self, name, lower=-np.inf, upper=np.inf, missing=np.nan):
        """scipy.optimize.NonlinearConstraint lower <= metric(x) <= upper (any minimize method)."""
        from scipy.optimize import NonlinearConstraint
        return NonlinearConstraint(self.metric(name, missing=missing), lower, upper)
