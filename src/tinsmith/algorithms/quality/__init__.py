"""Meshes for 2-D solvers: an error bound and an angle bound together.

The method's own module first, its helpers after it:

- :mod:`.quality`: quality meshes with an error bound: Delaunay refinement (Ruppert, Üngör's off-centres)
  plus the exact vertical error.
- :mod:`.regions`: areas with a size of their own (a river channel finer than its floodplain), for :mod:`.quality`.
"""
