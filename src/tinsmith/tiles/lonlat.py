"""pyproj's transformers between the DEM's CRS and longitude/latitude (WGS84), one per CRS, kept."""

from __future__ import annotations

import functools

__all__ = ["from_lonlat", "to_lonlat"]


@functools.lru_cache(maxsize=4)
def from_lonlat(crs: str):
    """From longitude and latitude to ``crs`` (x, y order)."""
    from pyproj import Transformer

    return Transformer.from_crs("EPSG:4326", crs, always_xy=True)


@functools.lru_cache(maxsize=4)
def to_lonlat(crs: str):
    """From ``crs`` to longitude and latitude (x, y order)."""
    from pyproj import Transformer

    return Transformer.from_crs(crs, "EPSG:4326", always_xy=True)
