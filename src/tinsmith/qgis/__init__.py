"""tinsmith in QGIS: a Processing provider (toolbox, model builder, batch runner) and the plugin that loads it.

Nothing here is imported by ``import tinsmith``: QGIS (its Python bindings,
3.22 or newer) is needed only by whoever imports this package, inside QGIS
or a script that runs ``QgsApplication``.

- :class:`TinsmithProvider` (:mod:`.provider`): the algorithms ``tinsmith:simplify``
  (every registered method, its options read from the registry),
  ``tinsmith:tile``, ``tinsmith:urban``, ``tinsmith:reconstruct``,
  ``tinsmith:metrics`` and ``tinsmith:report`` (:mod:`.algorithms`).
- :func:`classFactory`: QGIS's plugin entry point (:mod:`.plugin`); ``python -m
  tinsmith.qgis install`` puts the plugin into a QGIS profile.

In a script::

    from qgis.core import QgsApplication
    from tinsmith.qgis import TinsmithProvider
    QgsApplication.processingRegistry().addProvider(TinsmithProvider())
    processing.run("tinsmith:simplify", {"INPUT": "dem.tif", "METHOD": "quality", "MAX_ERROR": 1.0,
                                         "OUTPUT": "mesh.nc"})
"""

from __future__ import annotations

__all__ = ["TinsmithProvider", "classFactory"]


def classFactory(iface):
    """The plugin object QGIS asks a plugin for (``iface``: QGIS's interface)."""
    from .plugin import TinsmithPlugin

    return TinsmithPlugin(iface)


def __getattr__(name: str):
    if name == "TinsmithProvider":
        from .provider import TinsmithProvider

        return TinsmithProvider
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
