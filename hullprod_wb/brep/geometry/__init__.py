"""Geometry of a BRep face from its records: batched surface evaluation (nurbs for B-spline and
Bezier surfaces, analytic_surfaces for OpenCascade's elementary ones, picked by
surface_eval), the fundamental forms, H and K (differential, eq:brephk), the integrand field
(u, v) -> J, K, H (face_field), trim curves in parameter space (pcurves), the trimmed domain
Omega of eq:brep_surface_integral (trimmed_domain), exact repairs of its loops
(trim_repair) and the isolated zeros of S_u x S_v inside the knot spans
(degenerate_points). Imports core, reading (the records) and cubature (root finding, tensor grids).
"""
