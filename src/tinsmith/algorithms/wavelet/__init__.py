"""Spline and wavelet filtering of city terrain steered by land use (Goebbels and Pohle-Fröhlich 2015).

The method's own module first, its helpers after it:

- :mod:`.wavelet`: spline and Haar-wavelet filtering of city terrain steered by land use, then the quadtree
  (Goebbels and Pohle-Fröhlich 2015).
- :mod:`.spline`: linear-spline best approximation of a heightfield on coarser scales
  (Goebbels and Pohle-Fröhlich 2015, section 3, Algorithm 1).
- :mod:`.haar`: haar wavelets for Goebbels and Pohle-Fröhlich (2015)'s non-linear low pass
  (section 4, Algorithms 2 and 3, formulas 3 and 4).
- :mod:`.landuse`: land use from GIS polygons: roles of features and the grid points they make important
  (Goebbels and Pohle-Fröhlich 2015, section 5).
- :mod:`.wavelet_table`: Goebbels and Pohle-Fröhlich (2015)'s Table 1 and the land-use roles: the wavelet filter's
  constants, without its code.
"""
