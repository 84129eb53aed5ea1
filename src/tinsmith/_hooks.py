"""The calls a layer makes into a layer above it, installed by the package's root.

A module imports only the layers under its own (the contracts of ``[tool.importlinter]``
in pyproject.toml, checked by ``lint-imports``).  Two features of a lower layer are
implemented above it:

- :class:`~tinsmith.core.TerrainMesh`'s conversions to other libraries' objects
  (``to_trimesh``, ``to_pyvista``, ``to_geodataframe``, ``to_xarray``, ``_repr_html_``)
  are the functions of :mod:`tinsmith.io.interop`, ``to_anuga`` is :mod:`tinsmith.io.flood`'s and
  ``to_xugrid`` :mod:`tinsmith.io.ugrid`'s;
- greedy insertion's ``workers`` option is a tiled run of :mod:`tinsmith.tiles`
  (:func:`tinsmith.tiles.run.tile_heightfield`, :func:`tinsmith.tiles.point_threads.tile_points`).

The lower layer calls :func:`call` with the hook's name.  ``tinsmith/__init__.py``, which
sits above every layer and which Python runs before any module of the package, installs
the functions (:func:`install`), so a hook is always there when it is called.
"""

from __future__ import annotations

from collections.abc import Callable

__all__ = ["call", "install"]

_INSTALLED: dict[str, Callable] = {}


def install(**hooks: Callable) -> None:
    """Install (or replace) the function behind each named hook."""
    _INSTALLED.update(hooks)


def call(name: str, *args, **kwargs):
    """Run the function installed for the hook ``name``."""
    return _INSTALLED[name](*args, **kwargs)
