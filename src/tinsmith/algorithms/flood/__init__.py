"""Meshes for explicit shallow-water solvers: the quality refinement with a time-step floor and the stream network.

- :mod:`.flood`: the method: expected depth, stream lines as breaklines, the floor, the report and the outline's
  solver segments.
"""
