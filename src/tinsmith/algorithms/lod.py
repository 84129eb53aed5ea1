"""Several levels of detail of one heightfield in one call, sharing the work where the method allows.

Greedy insertion refines one engine from the coarsest level to the finest
(:meth:`GreedyEngine.levels`), the quadtree extracts every level from one
hierarchy (:class:`QuadtreeHierarchy`), decimation reads every level off one
collapse sequence (:class:`Decimation`); any other method runs once per level.
"""

from __future__ import annotations

from .. import _checks
from ..core import Heightfield, StopCriteria, TerrainMesh
from ..errors import InvalidOptionError
from ..resources import check_memory, estimate_method
from .greedy.engine import GreedyEngine
from .grid.decimate import Decimation
from .grid.quadtree import QuadtreeHierarchy
from .registry import fit_geometry, get_method

__all__ = ["levels_of_detail"]


def levels_of_detail(
    hf: Heightfield, method: str = "greedy", *, max_errors=None, max_vertices=None, **options
) -> list[TerrainMesh]:
    """One mesh per level, in the order given: by error bound (``max_errors``) or vertex budget (``max_vertices``).

    Parameters
    ----------
    hf : Heightfield
    method : str
        A registered method with stop rules.
    max_errors, max_vertices : sequence of numbers
        The levels; exactly one of the two.
    **options
        The method's own options (for example ``strict`` of the quadtree).

    Returns
    -------
    list of TerrainMesh
        ``mesh.info["level"]`` is the level's index and ``mesh.info["rule"]``
        its stop rule.
    """
    record = get_method(method)
    if not record.stop_rules:
        raise InvalidOptionError(f"method {record.name!r} takes no stop rules, so it has no levels of detail")
    if (max_errors is None) == (max_vertices is None):
        raise InvalidOptionError("give the levels as max_errors or as max_vertices, not both or neither")
    key = "max_error" if max_errors is not None else "max_vertices"
    values = list(max_errors if max_errors is not None else max_vertices)
    if not values:
        raise InvalidOptionError(f"give at least one level ({key})")
    repeated = sorted({v for v in values if values.count(v) > 1})
    if repeated:
        raise InvalidOptionError(f"{key} lists the level {repeated[0]} more than once, got {values}; give each level once")
    record.bind({**options, key: values[0]})  # names and types of the options, before any work
    options = dict(options)
    fit_geometry(record, options, hf)  # once for every level: read, reprojected and clipped, said once
    if isinstance(hf, Heightfield):  # the shared engines below bypass the registry's own check
        check_memory(estimate_method(record.name, hf.n_cells), f"making levels of detail by {record.name!r} on "
                     f"{hf.shape[0]:,} x {hf.shape[1]:,} cells", "'tinsmith tile' meshes a DEM of any size in windows")
    for v in values:
        if key == "max_error":
            _checks.number("max_error", v, minimum=0.0)
        else:
            _checks.integer("max_vertices", v, minimum=3)
    meshes = _shared(record.name, hf, key, values, options)
    if meshes is None:
        meshes = [record.function(hf, **options, **{key: v}) for v in values]
    for i, (mesh, v) in enumerate(zip(meshes, values, strict=True)):
        mesh.info["level"] = i
        mesh.info["rule"] = {key: v}
    return meshes


def _shared(name: str, hf: Heightfield, key: str, values: list, options: dict):
    """The levels from one engine or one hierarchy, where the method has one; None otherwise."""
    if name == "greedy" and not options:
        engine = GreedyEngine(hf)
        if key == "max_error":
            meshes = engine.levels(values)
        else:
            by_count = {}
            for n in sorted(set(values)):  # coarsest first: the engine only refines
                engine.refine(max_vertices=n)
                by_count[n] = engine.to_mesh()
            meshes = [by_count[n] for n in values]
        for mesh in meshes:
            mesh.info["method"] = "greedy"
        return meshes
    if name == "quadtree" and set(options) <= {"strict", "diagonal"}:
        tree = QuadtreeHierarchy(hf, **options)
        meshes = []
        for v in values:
            bound = v if key == "max_error" else tree.threshold_for_counts(max_vertices=v)
            mesh = tree.mesh(bound)
            mesh.info["method"] = "quadtree"
            meshes.append(mesh)
        return meshes
    if name == "decimate" and not options:
        dec = Decimation(hf)
        meshes = []
        for v in values:
            mesh = dec.mesh(dec.steps_for(StopCriteria(**{key: v})))
            mesh.info["method"] = "decimate"
            meshes.append(mesh)
        return meshes
    return None
