"""GUI side of the workbench: commands, task panels, view providers, colour maps, legends.

Presentation only: every number shown comes from the analysis object's properties, its
JSON document or its stored fields (hullprod_wb.app)."""
