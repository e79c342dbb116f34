"""Quasi-zero thresholds and the curvature-class field (paper eq:class_thresholds,
eq:curvature_classes)."""
from dataclasses import dataclass

import numpy as np

from .constants import (CLASS_ELLIPTIC, CLASS_FLAT, CLASS_INVALID, CLASS_SADDLE, CLASS_SINGLE,
                        DEFAULT_HF, DEFAULT_KF)
from .errors import InputError


@dataclass(frozen=True)
class Thresholds:
    """Dimensionless tolerances h_f, k_f and reference length L_ref.

    tau_H = h_f / L_ref and tau_K = k_f / L_ref^2 (eq:class_thresholds).
    """

    lref: float
    h_f: float = DEFAULT_HF
    k_f: float = DEFAULT_KF

    def __post_init__(self):
        check_positive("reference length L_ref", self.lref)
        check_positive("h_f", self.h_f)
        check_positive("k_f", self.k_f)

    @property
    def tau_H(self):
        return self.h_f / self.lref

    @property
    def tau_K(self):
        return self.k_f / self.lref ** 2

    def to_dict(self):
        return {"h_f": self.h_f, "k_f": self.k_f, "tau_H": self.tau_H, "tau_K": self.tau_K}


def check_positive(name, value):
    """Raise InputError unless value is a finite number > 0."""
    try:
        x = float(value)
    except (TypeError, ValueError):
        raise InputError("%s must be a number, got %r" % (name, value)) from None
    if not np.isfinite(x) or x <= 0.0:
        raise InputError("%s must be a finite number > 0, got %r" % (name, value))
    return x


def classify(K, H, tau_H, tau_K, valid=None):
    """Curvature class per sample (eq:curvature_classes).

    K, H: (n,) float; valid: (n,) bool or None. Returns (n,) int8 with
    -1 invalid, 0 flat (|K|<=tau_K, |H|<=tau_H), 1 single (|K|<=tau_K, |H|>tau_H),
    2 elliptic (K>tau_K), 3 saddle (K<-tau_K).
    """
    K = np.asarray(K, dtype=float)
    H = np.asarray(H, dtype=float)
    cls = np.full(K.shape, CLASS_INVALID, dtype=np.int8)
    ok = np.isfinite(K) & np.isfinite(H)
    if valid is not None:
        ok &= np.asarray(valid, dtype=bool)
    small_k = np.abs(K) <= tau_K
    cls[ok & small_k & (np.abs(H) <= tau_H)] = CLASS_FLAT
    cls[ok & small_k & (np.abs(H) > tau_H)] = CLASS_SINGLE
    cls[ok & (K > tau_K)] = CLASS_ELLIPTIC
    cls[ok & (K < -tau_K)] = CLASS_SADDLE
    return cls
