"""tinsmith as a QGIS plugin: it adds the Processing provider when QGIS starts, and installs itself into a profile.

QGIS finds a plugin as a folder of its profile's ``python/plugins`` with a
``metadata.txt`` and an ``__init__.py`` that defines ``classFactory``.
:func:`install` writes that folder (``tinsmith_processing``): two small files
that import this package, so the plugin is always the tinsmith installed in
QGIS's Python (``pip install tinsmith`` into it, or into a virtual
environment made with ``--system-site-packages``).  One command::

    python -m tinsmith.qgis install            # the default profile
    python -m tinsmith.qgis install --profile work --qgis-dir ~/.local/share/QGIS/QGIS3
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

from .._version import __version__

__all__ = ["PLUGIN", "TinsmithPlugin", "install", "metadata", "profiles_dir"]

#: The plugin's folder name in a profile.
PLUGIN = "tinsmith_processing"


class TinsmithPlugin:
    """The object QGIS keeps for the plugin: the provider in, on start; out, on unload."""

    def __init__(self, iface=None):
        self.iface = iface
        self.provider = None

    def initProcessing(self) -> None:
        from qgis.core import QgsApplication

        from .provider import TinsmithProvider

        if self.provider is None:
            self.provider = TinsmithProvider()
            QgsApplication.processingRegistry().addProvider(self.provider)

    def initGui(self) -> None:
        self.initProcessing()

    def unload(self) -> None:
        from qgis.core import QgsApplication

        if self.provider is not None:
            QgsApplication.processingRegistry().removeProvider(self.provider)
            self.provider = None


def metadata() -> str:
    """The plugin's ``metadata.txt`` (no repository, tracker or e-mail: those the plugin repository asks for
    when one is published there)."""
    return "\n".join([
        "[general]",
        "name=tinsmith",
        "qgisMinimumVersion=3.22",
        "description=Elevation data (DEMs, LiDAR, dense meshes) to compact, well-shaped triangle meshes",
        f"version={__version__}",
        "author=tinsmith developers",
        "about=A Processing provider: simplify a DEM with any of tinsmith's methods (quality and flood meshes for "
        "2-D solvers among them), tile large DEMs, city models of DSMs, surfaces of point clouds, metrics and "
        "reports. Meshes load as mesh layers (2DM, UGRID NetCDF) with their CRS. Needs the tinsmith Python "
        "package in QGIS's Python: pip install tinsmith.",
        "tags=mesh,tin,dem,terrain,flood,ugrid,2dm,lidar,processing",
        "category=Analysis",
        "hasProcessingProvider=yes",
        "experimental=False",
        "",
    ])


_INIT = '''"""The tinsmith QGIS plugin: the code is the tinsmith package in QGIS's Python (pip install tinsmith)."""


def classFactory(iface):
    from tinsmith.qgis import classFactory as factory

    return factory(iface)
'''


def profiles_dir() -> Path:
    """QGIS 3's folder of profiles for this user (``QGIS_CUSTOM_CONFIG_PATH`` honoured)."""
    custom = os.environ.get("QGIS_CUSTOM_CONFIG_PATH")
    if custom:
        return Path(custom) / "profiles"
    if sys.platform == "win32":
        return Path(os.environ.get("APPDATA", Path.home())) / "QGIS" / "QGIS3" / "profiles"
    if sys.platform == "darwin":
        return Path.home() / "Library" / "Application Support" / "QGIS" / "QGIS3" / "profiles"
    return Path(os.environ.get("XDG_DATA_HOME", Path.home() / ".local" / "share")) / "QGIS" / "QGIS3" / "profiles"


def install(profile: str = "default", qgis_dir=None) -> Path:
    """Write the plugin folder into a QGIS profile; return it.  Enable it once in QGIS (Plugins > Manage)."""
    from ..io._atomic import atomic_paths

    base = Path(qgis_dir) / "profiles" if qgis_dir else profiles_dir()
    folder = base / profile / "python" / "plugins" / PLUGIN
    folder.mkdir(parents=True, exist_ok=True)
    with atomic_paths(folder / "__init__.py", folder / "metadata.txt") as (init, meta):
        init.write_text(_INIT, encoding="utf-8")
        meta.write_text(metadata(), encoding="utf-8")
    return folder
