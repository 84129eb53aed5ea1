"""Pictures of meshes (optional extra ``viz``: matplotlib): PNG figures, the HTML report, the 3-D viewer."""

from . import report, viewer
from .figures import (
           plot_contours,
           plot_error,
           plot_hillshades,
           plot_quality,
           plot_wireframe,
)
from .plot import plot_mesh

__all__ = ["plot_contours", "plot_error", "plot_hillshades", "plot_mesh", "plot_quality", "plot_wireframe",
           "report", "viewer"]
