"""Many hulls at once: batch assessment locally in parallel or on a Dask cluster, and the
signature as a function of design parameters for optimisation loops."""
from .api import BatchResult, assess_many, run_batch  # noqa: F401
from .objective import SignatureObjective  # noqa: F401
from .parametric import DocumentHull  # noqa: F401
