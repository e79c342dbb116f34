"""Constants of the signature: default tolerances, class ids, metric names.

All tolerances are dimensionless; they become curvature thresholds through the
reference length (paper eq:class_thresholds).
"""

#: Default dimensionless quasi-zero tolerances h_f and k_f (paper section 3.2).
DEFAULT_HF = 1.0e-4
DEFAULT_KF = 1.0e-4

#: Curvature-class ids of the categorical field c(x) (paper eq:curvature_classes).
CLASS_INVALID = -1
CLASS_FLAT = 0
CLASS_SINGLE = 1
CLASS_ELLIPTIC = 2
CLASS_SADDLE = 3
CLASS_NAMES = ("flat", "single", "elliptic", "saddle")

#: The seven scalar entries of the signature vector I_sig (paper eq:vector), in order.
METRICS = ("I_D", "I_D_plus", "I_D_minus", "a_flat", "a_single", "a_elliptic", "a_saddle")
CLASS_METRICS = METRICS[3:]

#: Human labels of the metrics, for tables and the GUI.
METRIC_LABELS = {
    "I_D": "I_D",
    "I_D_plus": "I_D+",
    "I_D_minus": "I_D-",
    "a_flat": "a_flat",
    "a_single": "a_single",
    "a_elliptic": "a_elliptic",
    "a_saddle": "a_saddle",
}

#: Version of the JSON document written by :meth:`Assessment.to_json`.
SCHEMA_VERSION = "1.0"

#: Explicit and automatic reference lengths disagreeing by more than this factor give a warning.
LREF_PLAUSIBLE_RATIO = 10.0
