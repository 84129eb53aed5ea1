"""tinsmith: elevation data (DEM rasters, LiDAR, dense meshes) to compact, well-shaped TINs.

The flat public API::

    import tinsmith
    hf = tinsmith.read_heightfield("dem.tif")          # or tinsmith.sample("st-helens")
    mesh = tinsmith.simplify(hf, method="grid")        # any name from tinsmith.methods()
    print(tinsmith.mesh_metrics(mesh, hf)["vertical_error"])
    tinsmith.write(mesh, "dem.ply")

Every method is also a function of its own, with one contract:
``tinsmith.<method>(data, *, max_error=None, max_vertices=None,
max_triangles=None, <its options>, progress=None) -> TerrainMesh``.

The public names are listed in ``__init__.pyi`` (what IDEs and type
checkers read) and imported on first use (PEP 562, through ``lazy_loader``),
so ``import tinsmith`` and the command line start at once and load numba,
scipy and the readers only for the work that needs them.
"""

from . import _hooks, _lazy

__getattr__, __dir__, __all__ = _lazy.attach(__name__, __file__)

# The calls a layer makes into a layer above it (tinsmith._hooks), installed here: this module sits above every
# layer, and Python runs it before any module of the package.  Each target is imported on its first call.
_hooks.install(
    tile_heightfield=_lazy.function("tinsmith.tiles.run", "tile_heightfield"),
    tile_points=_lazy.function("tinsmith.tiles.point_threads", "tile_points"),
    **{name: _lazy.function("tinsmith.io.interop", name)
       for name in ("to_trimesh", "to_pyvista", "to_geodataframe", "to_xarray", "repr_html")},
    to_anuga=_lazy.function("tinsmith.io.flood", "to_anuga"),
    to_xugrid=_lazy.function("tinsmith.io.ugrid", "to_xugrid"),
)
