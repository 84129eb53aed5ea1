"""Spline and wavelet filtering of city terrain steered by land use (seed 004).

The method's own module first, its helpers after it:

- :mod:`.wavelet`: spline and Haar-wavelet filtering of city terrain steered by land use, then the quadtree (seed 004).
- :mod:`.spline`: linear-spline best approximation of a heightfield on coarser scales (seed 004, section 3, Algorithm 1).
- :mod:`.haar`: haar wavelets for seed 004's non-linear low pass (section 4, Algorithms 2 and 3, formulas 3 and 4).
- :mod:`.landuse`: land use from GIS polygons: roles of features and the grid points they make important (seed 004, section 5).
- :mod:`.wavelet_table`: seed 004's Table 1 and the land-use roles: the wavelet filter's constants, without its code.
"""
