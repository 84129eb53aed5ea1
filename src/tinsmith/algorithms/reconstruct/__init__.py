"""Projection-based surface reconstruction of point clouds (seed 001).

The method's own module first, its helpers after it:

- :mod:`.reconstruct`: projection-based surface reconstruction of point clouds in linear time (seed 001, Gopi and Krishnan 2002).
- :mod:`.projection`: general mode of the projection-based reconstruction (seed 001, section 4; Gopi and Krishnan 2002).
"""
