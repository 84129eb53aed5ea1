"""Greedy insertion and the constrained Delaunay triangulation it runs on.

The method's own module first, its helpers after it:

- :mod:`.greedy`: greedy insertion (HFPR): refine a Delaunay TIN by inserting the worst cell, again and again.
- :mod:`.greedy_points`: greedy insertion on a point cloud: the error is exact at every kept input point, no gridding.
- :mod:`.pointtin`: the TIN of a point cloud: the 2.5-D Delaunay triangulation of its points, cut to their concave outline.
- :mod:`.pointconstraints`: constraints of a point-cloud TIN from vectors: breaklines, polygons left open, flat water polygons.
- :mod:`.delaunay`: constrained Delaunay triangulation of points in the plane, on the kernel greedy insertion uses.
- :mod:`.outline`: the outline of the data in a grid with nodata, as segments between cell centres.
"""
