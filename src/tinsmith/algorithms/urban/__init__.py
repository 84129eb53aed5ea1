"""Urban surface models and city meshes (the Salt Lake City thesis, chapter 4).

The method's own module first, its helpers after it:

- :mod:`.urban`: urban surface models: standard-deviation thresholds and collapsed contouring
  (the Salt Lake City thesis, chapter 4).
- :mod:`.ground`: the ground under a surface model or a point cloud: a progressive morphological filter that holds
  on hills.
- :mod:`.buildings`: which cells of a surface model are buildings, and which building each belongs to.
- :mod:`.blocks`: the block model of a building tree: flat roofs, vertical walls and the ground, as one crack-free surface.
- :mod:`.roofs`: roofs of buildings: one flat height per building (LoD 1.2), or planar roof facets (LoD 2-like).
- :mod:`.regularize`: building outlines people accept: staircases of grid cells made into straight walls at right angles.
- :mod:`.city`: a city model from a surface model: buildings found (or given as footprints), roofs, and the terrain, in one mesh.
- :mod:`.citymesh`: one mesh of a city: the terrain with every building welded into it, open or closed into a CFD-ready solid.
"""
