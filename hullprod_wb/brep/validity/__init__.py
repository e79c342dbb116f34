"""Whether a BRep metric can be trusted (paper section 4.3): the work and error budgets and
protocols (budget), the validity rules of the metrics over the assessed faces (metric_rules),
the degenerate points, graded refinement and the nested-neighbourhood audit (singular), the
whitened polar rule at pinch points (pinch_points), the cross-checks against OpenCascade and a fixed rule (cross_checks), and the faces left out of
an assessment (left_out). Imports core, reading, geometry and cubature, never the run above.
"""
