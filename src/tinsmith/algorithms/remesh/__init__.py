"""Isotropic remeshing with an exact vertex budget (Alliez et al. 2003).

The method's own module first, its helpers after it:

- :mod:`.remesh`: isotropic remeshing with an exact vertex budget: error diffusion and weighted CVT with features
  (Alliez et al. 2003).
- :mod:`.sampling`: exactly N samples on a triangle mesh by error diffusion (Alliez et al. 2003, section 3):
  the remesher's first stage.
- :mod:`.skeleton`: the feature skeleton of a triangle mesh: feature edges chained into backbones, and corners
  (Alliez et al. 2003, section 2).
- :mod:`.parameterize`: parameter spaces for the remesher (Alliez et al. 2003, section 4.2): the x-y plane for
  terrain, LSCM otherwise.
- :mod:`.relax`: the relaxation: 1-D Lloyd on the backbones, weighted 2-D Lloyd in parameter space (Alliez et al. 2003, 4.3-4.4).
- :mod:`.charts`: closed and higher-genus meshes cut into disk-like charts and remeshed chart by chart (Alliez et al. 2003, 4.1).
- :mod:`.seams`: the seams of a chart-by-chart remesh relaxed by flips and Lloyd steps on the surface.
"""
