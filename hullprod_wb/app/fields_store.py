"""Distributed fields kept with an analysis object: a compressed .npz file.

The analysis stores it in an App::PropertyFileIncluded, so colour maps and the probe
work after the document is saved and reopened, without recomputing.
"""
import numpy as np

from ..core.errors import InputError
from ..core.fields import DistributedFields

_ARRAYS = ("points", "triangles", "K", "H", "valid")
_SCALARS = ("lref", "tau_H", "tau_K")


def save_fields(fields, path):
    """Write DistributedFields to path (.npz); extra arrays are stored as 'extra_<name>'."""
    data = {name: np.asarray(getattr(fields, name)) for name in _ARRAYS}
    data.update({name: np.float64(getattr(fields, name)) for name in _SCALARS})
    data["kind"] = np.array(fields.kind)
    if fields.weights is not None:
        data["weights"] = np.asarray(fields.weights, float)
    for key, arr in (fields.extra or {}).items():
        data["extra_" + key] = np.asarray(arr)
    np.savez_compressed(path, **data)
    return path


def load_fields(path):
    """Read DistributedFields written by save_fields."""
    try:
        with np.load(path, allow_pickle=False) as z:
            d = {k: z[k] for k in z.files}
    except (OSError, ValueError) as exc:
        raise InputError("cannot read the stored fields %s: %s" % (path, exc)) from None
    missing = [k for k in _ARRAYS + _SCALARS if k not in d]
    if missing:
        raise InputError("stored fields %s lack %s" % (path, ", ".join(missing)))
    extra = {k[len("extra_"):]: v for k, v in d.items() if k.startswith("extra_")}
    return DistributedFields(points=d["points"].astype(float), triangles=d["triangles"].astype(np.int64),
                             K=d["K"].astype(float), H=d["H"].astype(float), valid=d["valid"].astype(bool),
                             lref=float(d["lref"]), tau_H=float(d["tau_H"]), tau_K=float(d["tau_K"]),
                             weights=d.get("weights"), kind=str(d["kind"]), extra=extra)
