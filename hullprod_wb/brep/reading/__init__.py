"""Reading a BRep: the only place that talks to OpenCascade's file readers. A user's file is
read in a child process (reader_process: forked from a clean process, else a fresh
interpreter), which turns each face into plain numbers (occ_records: poles, knots, weights,
p-curves, OpenCascade's cross-check values), makes the tessellations for display and the
automatic reference length (lref_samples) and the shape's provenance (provenance), and sends
them to the parent (record_reader); loading gives Part shapes and FreeCAD objects the same
form. Imports only core and freecad_env, and never numpy at import time (the child stays light).
"""
