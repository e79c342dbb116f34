"""Metric-specific validity (paper section 4.3, sec:metric_validity).

Validity is attached to each signature metric, never to the hull as a whole. A metric
whose status does not establish a value (UNCONVERGED, SINGULAR, NOT EVALUATED, N/A)
carries value None; a finite candidate may be kept in the evidence, never as the value.
"""
from dataclasses import dataclass, field
from enum import Enum

import numpy as np


class Status(str, Enum):
    """Public display labels of the validity vocabulary."""

    VALID = "VALID"                    #: established, usable value
    VALID_STAR = "VALID*"              #: convergent improper integral near a measure-zero singular set
    CAUTION = "CAUTION"                #: finite, with a stated qualification
    UNCONVERGED = "UNCONVERGED"        #: bounded refinement did not establish convergence
    SINGULAR = "SINGULAR"              #: non-integrable geometric singularity
    MESH_SENSITIVE = "MESH-SENSITIVE"  #: mesh result dependent on resolution/connectivity/quality
    NOT_EVALUATED = "NOT EVALUATED"    #: not computed in this run
    NOT_APPLICABLE = "N/A"             #: not applicable to this representation

    def __str__(self):
        return self.value


#: Statuses under which the metric value is established and reported.
ESTABLISHED = frozenset({Status.VALID, Status.VALID_STAR, Status.CAUTION, Status.MESH_SENSITIVE})

#: Plain-language meaning of each label, for tables, reports and the GUI.
STATUS_MEANING = {
    Status.VALID: "established, usable value",
    Status.VALID_STAR: "convergent improper integral; singular points recorded",
    Status.CAUTION: "finite value that needs the stated qualification",
    Status.UNCONVERGED: "refinement did not establish a value",
    Status.SINGULAR: "integral does not exist (non-integrable singularity)",
    Status.MESH_SENSITIVE: "mesh value that depends on resolution, connectivity or quality",
    Status.NOT_EVALUATED: "not computed",
    Status.NOT_APPLICABLE: "not applicable to this representation",
}

#: Order of severity, used to summarise several records (worst first wins).
SEVERITY = [Status.SINGULAR, Status.UNCONVERGED, Status.NOT_EVALUATED, Status.MESH_SENSITIVE,
            Status.CAUTION, Status.VALID_STAR, Status.VALID, Status.NOT_APPLICABLE]


def joined_reason(reason, more):
    """The sentence more after reason, '; ' between them (either may be empty)."""
    return (reason + "; " if reason else "") + more


def finite_or_none(x):
    """float(x) when finite, else None (JSON never carries NaN or inf)."""
    try:
        x = float(x)
    except (TypeError, ValueError):
        return None
    return x if np.isfinite(x) else None


@dataclass
class MetricValidity:
    """Validity record of one signature metric.

    status: display label; value: established value or None; reason: plain sentence;
    code: detailed machine-readable classification (e.g. 'converged',
    'convergent_improper', 'quadrature_unresolved'); represented_area, valid_area: areas
    the metric was formed over; evidence: numbers supporting the status.
    """

    status: Status
    value: object
    reason: str = ""
    code: str = ""
    represented_area: object = None
    valid_area: object = None
    evidence: dict = field(default_factory=dict)

    def __post_init__(self):
        self.status = Status(self.status)
        v = finite_or_none(self.value)
        if self.status not in ESTABLISHED or v is None:
            if v is not None:
                self.evidence.setdefault("finite_candidate", v)
            if self.status in ESTABLISHED:
                # A non-finite value can never be established.
                self.status = Status.UNCONVERGED
                self.reason = joined_reason(self.reason, "value is not finite")
                self.code = self.code or "non_finite"
            v = None
        self.value = v

    @property
    def established(self):
        return self.status in ESTABLISHED

    def qualify(self, q):
        """Apply the Qualification q: its evidence entries added; CAUTION with q.code where the
        status is VALID or VALID* (q.caution); q.reason (when given) after the reason."""
        self.evidence.update(q.evidence)
        if q.caution and self.status in ESTABLISHED and self.status != Status.CAUTION:
            self.status, self.code = Status.CAUTION, q.code
        if q.reason:
            self.reason = joined_reason(self.reason, q.reason)

    def to_dict(self):
        return {
            "status": self.status.value,
            "value": self.value,
            "reason": self.reason,
            "code": self.code,
            "represented_area": finite_or_none(self.represented_area),
            "valid_area": finite_or_none(self.valid_area),
            "evidence": self.evidence,
        }


@dataclass(frozen=True)
class Qualification:
    """What qualifies a metric's validity beyond its own rule, the one way a record is changed
    after it is made (MetricValidity.qualify, qualify_all): code, the machine-readable name
    of the qualification, given to a VALID or VALID* record that becomes CAUTION (caution);
    reason, the sentence added to the record's reason (empty: none); evidence, the entries
    added to its evidence."""

    code: str
    reason: str = ""
    evidence: dict = field(default_factory=dict)
    caution: bool = True


def qualify_all(validity, q, metrics=None):
    """Apply the Qualification q to the records of validity (name -> MetricValidity), or to
    those of metrics only."""
    for name, rec in validity.items():
        if metrics is None or name in metrics:
            rec.qualify(q)


def worst(statuses):
    """The most severe status among several (for one-line summaries)."""
    statuses = [Status(s) for s in statuses]
    for s in SEVERITY:
        if s in statuses:
            return s
    return Status.NOT_EVALUATED
