"""The Processing provider: tinsmith's algorithms in QGIS's toolbox under the id ``tinsmith``."""

from __future__ import annotations

from qgis.core import QgsProcessingProvider

from .._version import __version__
from .algorithms import ALGORITHMS


class TinsmithProvider(QgsProcessingProvider):
    """tinsmith's algorithms (:data:`.algorithms.ALGORITHMS`) for QGIS Processing."""

    def id(self) -> str:
        return "tinsmith"

    def name(self) -> str:
        return "tinsmith"

    def longName(self) -> str:
        return f"tinsmith {__version__}: elevation data to triangle meshes"

    def versionInfo(self) -> str:
        return __version__

    def loadAlgorithms(self) -> None:
        for algorithm in ALGORITHMS:
            self.addAlgorithm(algorithm())
