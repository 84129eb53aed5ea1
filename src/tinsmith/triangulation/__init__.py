"""The triangulation every method builds on: shared geometry above the data model, under metrics, io and methods.

- :mod:`.delaunay`: constrained Delaunay triangulation of points in the plane (``tinsmith.delaunay``), and the
  kernel's triangulation tuple the methods work on.
- :mod:`.pointtin`: the TIN of a point cloud (``tinsmith.tin``): its 2.5-D Delaunay triangulation, cut to the
  points' concave outline.
- :mod:`.pointconstraints`: constraints of a point-cloud TIN from vectors: breaklines, polygons left open, flat
  water polygons.
- :mod:`.grid`: the full-resolution triangulation of a grid (the diagonal rule, lattice meshes), and its heights
  filled across nodata.
- :mod:`.outline`: the outline of the data in a grid with nodata, as segments between cell centres.
- :mod:`.breaklines`: breaklines and control points on a grid, snapped to cell centres and split where they cross.
- :mod:`.edges`: edges of a triangle mesh: the twins two triangles share, the border.
- :mod:`.sampling`: a TIN's heights at the cell centres of a grid (``tinsmith.rasterize``).

Importing this package imports none of its modules (most of them load numba kernels).
"""
