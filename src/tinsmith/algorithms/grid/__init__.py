"""The grid and its simplifications: full grid, subsampling, quadtree, feature points, decimation.

The method's own module first, its helpers after it:

- :mod:`.grid`: full-resolution grid triangulation: every valid cell centre a vertex.
- :mod:`.subsample`: regular subsampling: every ``step``-th row and column of the grid, triangulated
  (the Salt Lake City thesis, section 2.1).
- :mod:`.quadtree`: crack-free quadtree triangulation: a right-triangulated irregular network (RTIN), as Martini.
- :mod:`.features`: feature points: rank the cells by importance, keep the top ones, Delaunay-triangulate
  (the Salt Lake City thesis, sections 2.3, 3.1.1).
- :mod:`.decimate`: decimation: quadric edge collapse from the full-resolution mesh
  (the Salt Lake City thesis, section 2.2; Garland and Heckbert 1997).
"""
