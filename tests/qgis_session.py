"""QGIS for the tests: Debian's python3-qgis, headless (``QT_QPA_PLATFORM=offscreen``), once per test process.

:func:`qgis_app` starts QGIS, its Processing framework and tinsmith's
provider, or skips the test when QGIS is not installed.  Debian's bindings
live in the system Python's ``dist-packages``; a virtual environment of the
same Python minor version imports them from there (appended to ``sys.path``,
so the environment's own packages come first).
"""

from __future__ import annotations

import os
import sys
import tempfile
from pathlib import Path
from types import SimpleNamespace

import pytest

#: Where Debian puts the bindings (python3-qgis) and the Processing plugin (python3-qgis-common).
DIST_PACKAGES = Path("/usr/lib/python3/dist-packages")
PLUGINS = Path("/usr/share/qgis/python/plugins")

_SESSION: dict = {}


def _import_qgis():
    try:
        import qgis.core  # noqa: F401
    except ImportError:
        if not (DIST_PACKAGES / "qgis").is_dir():
            return False
        sys.path.append(str(DIST_PACKAGES))
        try:
            import qgis.core  # noqa: F401
        except ImportError:
            return False
    return True


def qgis_app() -> SimpleNamespace:
    """``(core, processing, provider, app)``: QGIS started headless with tinsmith's provider; skips without QGIS."""
    if "app" in _SESSION:
        return _SESSION["app"]
    os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")
    if "XDG_RUNTIME_DIR" not in os.environ:  # Qt wants one of its own (0700)
        os.environ["XDG_RUNTIME_DIR"] = tempfile.mkdtemp(prefix="xdg-")
    os.environ.setdefault("GDAL_PAM_ENABLED", "NO")  # no .aux.xml statistics written beside the inputs
    if not _import_qgis():
        pytest.skip("QGIS is not installed (Debian: apt-get install python3-qgis qgis-providers)")
    from qgis import core

    core.QgsApplication.setPrefixPath("/usr", True)
    app = core.QgsApplication([], False)
    app.initQgis()
    if str(PLUGINS) not in sys.path:
        sys.path.append(str(PLUGINS))
    import processing
    from processing.core.Processing import Processing

    Processing.initialize()
    from tinsmith.qgis.provider import TinsmithProvider

    provider = TinsmithProvider()  # kept: QGIS does not own a provider made in Python
    core.QgsApplication.processingRegistry().addProvider(provider)
    _SESSION["app"] = SimpleNamespace(core=core, processing=processing, provider=provider, app=app)
    return _SESSION["app"]


def mesh_layer(path, name: str = "mesh"):
    """``path`` opened by QGIS (MDAL) as a mesh layer."""
    from qgis.core import QgsMeshLayer

    return QgsMeshLayer(str(path), name, "mdal")
