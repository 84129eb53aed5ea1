"""Greedy insertion: refine a Delaunay TIN at the worst cell (or input point) until the error bound holds.

The method's own module first, its engines after it:

- :mod:`.greedy`: the method: on a DEM, on a point cloud, or in tiles on threads (``workers``).
- :mod:`.engine`: greedy insertion on a grid (HFPR): refine a Delaunay TIN by inserting the worst cell, again and again.
- :mod:`.greedy_points`: greedy insertion on a point cloud: the error is exact at every kept input point, no gridding.

The triangulation it runs on, the TIN of a point cloud and the nodata outline are shared by
every method: :mod:`tinsmith.triangulation`.
"""
