"""tinsmith in QGIS: a Processing provider (toolbox, model builder, batch runner) and the plugin that loads it.

Nothing here is imported by ``import tinsmith``. QGIS (its Python bindings,
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

from ..errors import MissingDependencyError

__all__ = ["TinsmithProvider", "classFactory"]

try:
    from .provider import TinsmithProvider
except ModuleNotFoundError as exc:  # no QGIS bindings here: the plugin's installer still runs
    if not (exc.name or "").startswith(("qgis", "PyQt")):
        raise

    def TinsmithProvider(*args, **kwargs):  # noqa: N802 - stands in for the class
        """Raises :class:`~tinsmith.errors.MissingDependencyError`: QGIS's Python bindings are not importable."""
        raise MissingDependencyError(
            "tinsmith.qgis.TinsmithProvider needs QGIS's Python bindings (qgis.core): run it inside QGIS, or install "
            "QGIS (Debian: apt-get install python3-qgis qgis-providers)")


def classFactory(iface):
    """The plugin object QGIS asks a plugin for (``iface``: QGIS's interface)."""
    from .plugin import TinsmithPlugin

    return TinsmithPlugin(iface)
