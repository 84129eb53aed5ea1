"""Sliver triangles in a solver's mesh: the one-line warning the writers of solver formats share.

A 2-D hydraulic or ocean solver (TUFLOW, BASEMENT, HEC-RAS through 2DM;
TELEMAC, ANUGA through Gmsh; ADCIRC through fort.14) takes its time step
from its smallest elements and loses accuracy on thin ones: a mesh whose
triangles have plan-view angles of a few degrees runs slowly or not at all.
Writers registered with ``solver=True`` (:func:`tinsmith.io.registry.writer`)
get :func:`sliver_warning` from the dispatcher (:func:`tinsmith.io.write`),
once per file, after the file is written.
"""

from __future__ import annotations

import numpy as np

from ..core import TerrainMesh
from ..errors import TinsmithWarning
from ..triangulation.shape import triangle_angles

__all__ = ["SLIVER_ANGLE", "SOLVER_MESHERS", "SliverWarning", "smallest_plan_angles", "sliver_warning"]

#: A triangle whose smallest plan-view (x, y) angle is below this many degrees is a sliver for a solver.
SLIVER_ANGLE = 10.0

#: The methods that mesh for a solver, with what they promise: the fix the warning names (in this order).
SOLVER_MESHERS = (("quality", "the 30-degree quality mesher"),)


class SliverWarning(TinsmithWarning):
    """A mesh written to a solver format (2DM, Gmsh, ADCIRC fort.14, TELEMAC SELAFIN) has sliver triangles (plan-view angles
    under :data:`SLIVER_ANGLE` degrees); the message counts them and names the method that avoids them."""


def smallest_plan_angles(mesh: TerrainMesh) -> np.ndarray:
    """(M,) the smallest interior angle of every triangle seen from above (x, y only), in degrees."""
    return triangle_angles(mesh, dims=2).min(axis=1)


def sliver_warning(mesh: TerrainMesh, name: str) -> str | None:
    """The one-line warning for writing ``mesh`` to the solver file ``name``, or None when it has no sliver."""
    if mesh.n_triangles == 0:
        return None
    angles = smallest_plan_angles(mesh)
    slivers = angles < SLIVER_ANGLE
    count = int(slivers.sum())
    if not count:
        return None
    fixes = " or ".join(f"--method {m} (method={m!r}: {what})" for m, what in SOLVER_MESHERS)
    return (
        f"{name!r}: {count:,} of {mesh.n_triangles:,} triangles ({count / mesh.n_triangles:.1%}) are slivers for "
        f"a solver, with a plan-view angle under {SLIVER_ANGLE:g} degrees (the smallest {float(angles.min()):.2g} degrees); "
        f"solvers take tiny time steps or fail on them: mesh with {fixes}"
    )
