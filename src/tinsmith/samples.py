"""Sample data shipped inside the package (small, openly licensed; see data/samples/PROVENANCE.md)."""

from __future__ import annotations

from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import TYPE_CHECKING

from .errors import InvalidInputError

if TYPE_CHECKING:
    from .core import Heightfield

__all__ = ["SAMPLES", "Sample", "sample", "sample_path"]


@dataclass(frozen=True)
class Sample:
    name: str
    file: str
    description: str
    licence: str


SAMPLES = {
    s.name: s
    for s in [
        Sample(
            "st-helens",
            "st_helens_30m.tif",
            "Mount St. Helens, WA, after the 1980 eruption: USGS 30 m DEM, 468 x 327 cells, "
            "NAD27 / UTM 10N (EPSG:26710), 682-2543 m, 2.7% nodata",
            "public domain (USGS)",
        ),
    ]
}


def sample_path(name: str) -> Path:
    """Path of the embedded sample ``name``; :class:`InvalidInputError` lists the names.

    Examples
    --------
    >>> import tinsmith
    >>> path = tinsmith.sample_path("st-helens")
    >>> path.name, path.is_file()
    ('st_helens_30m.tif', True)
    """
    try:
        sample = SAMPLES[name]
    except (KeyError, TypeError):
        raise InvalidInputError(f"unknown sample {name!r}; choose one of: {', '.join(SAMPLES)}") from None
    return Path(str(resources.files("tinsmith") / "data" / "samples" / sample.file))


def sample(name: str = "st-helens") -> Heightfield:
    """The embedded sample heightfield ``name`` (see :data:`SAMPLES`), read with :func:`tinsmith.read_heightfield`.

    Examples
    --------
    >>> import tinsmith
    >>> tinsmith.sample("st-helens")
    Heightfield(468 x 327, cell 30 x 30, z 682..2543, nodata 2.7%, crs=yes)
    """
    from .io import read_heightfield  # numpy and rasterio load with the first read, not with the package

    return read_heightfield(sample_path(name))
