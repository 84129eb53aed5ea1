"""Curvature CVT multiresolution DEMs (Duan et al. 2016).

The method's own module first, its helpers after it:

- :mod:`.cvt`: curvature centroidal Voronoi tessellation (cCVT): quasi-uniform, terrain-adaptive TINs
  (Duan et al. 2016, Algorithm 2).
- :mod:`.curvature`: mean curvature of a DEM and the curvature density of the cCVT
  (Duan et al. 2016, section 2; Meyer et al. 2003).
- :mod:`.fit`: fitted heights: the least-squares heights of a mesh's vertices against every cell it covers
  (Duan et al. (2016)'s TINs, and beyond).
"""
