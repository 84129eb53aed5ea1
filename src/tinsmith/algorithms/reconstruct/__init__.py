"""Projection-based surface reconstruction of point clouds (Gopi and Krishnan 2002).

The method's own module first, its helpers after it:

- :mod:`.reconstruct`: projection-based surface reconstruction of point clouds in linear time
  (Gopi and Krishnan 2002, Gopi and Krishnan 2002).
- :mod:`.projection`: general mode of the projection-based reconstruction
  (Gopi and Krishnan 2002, section 4; Gopi and Krishnan 2002).
"""
