"""Pictures of meshes (optional extra ``viz``: matplotlib)."""

from .plot import plot_mesh

__all__ = ["plot_mesh"]
