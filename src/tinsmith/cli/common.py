"""What the commands share: reading the input and its options, measuring the mesh, naming the input in errors."""

from __future__ import annotations

import contextlib
import re
from pathlib import Path

import click

from .. import _lazy, core
from ..algorithms.registry import methods
from ..errors import FileError, InvalidInputError, InvalidOptionError
from ..io import (
    read,
    read_heightfield,
    reader_for,
)
from ..samples import sample_path
from .options import READ_KEYS
from .params import cloud_inputs

# numba, scipy and the methods load when a command first calls them, not at start-up
compare_methods = _lazy.function("tinsmith.algorithms.compare", "compare_methods")
fit = _lazy.function("tinsmith.algorithms.cvt.fit", "fit_heights")
levels_of_detail = _lazy.function("tinsmith.algorithms.lod", "levels_of_detail")
wavelet_mesh = _lazy.function("tinsmith.algorithms.wavelet.wavelet", "wavelet_model")
wavelet_filter = _lazy.function("tinsmith.algorithms.wavelet.wavelet", "wavelet_filter")
read_clouds = _lazy.function("tinsmith.io.points", "read_clouds")
mesh_metrics = _lazy.function("tinsmith.metrics", "mesh_metrics")
#: the vertical error against the source, as every command reports it (tinsmith.metrics.source_error)
measure = _lazy.function("tinsmith.metrics.vertical", "source_error")
vertical_error = _lazy.function("tinsmith.metrics.vertical", "vertical_error")


def check_html_output(path: str) -> Path:
    """An HTML output's name: a .html suffix, in a folder that exists."""
    out = Path(path)
    if out.suffix.lower() not in (".html", ".htm"):
        raise click.BadParameter(f"expected a .html file name, got {path!r}", param_hint="'-o'")
    if not (out.parent if str(out.parent) else Path(".")).is_dir():
        raise FileError(f"output folder {str(out.parent)!r} does not exist (for {out.name!r})")
    return out


def input_path(path, sample):
    if path and sample:
        raise click.UsageError("give an input file or --sample, not both")
    if sample:
        return str(sample_path(sample)), f"sample {sample}"
    if not path:
        raise click.UsageError("missing input: give a file or --sample NAME")
    return path, path


def inputs_of(inputs, sample):
    """``(path, label)`` of one input, or ``(files, label)`` of several point clouds (files, folders, globs)."""
    clouds = cloud_files(inputs, sample)
    if clouds is not None and (len(inputs) > 1 or len(clouds) > 1 or not Path(inputs[0]).is_file()):
        return clouds, label_of(clouds)
    return input_path(inputs[0] if inputs else None, sample)


def reader_options(opts) -> dict:
    return {k: opts[k] for k in READ_KEYS}


def load_heightfield(path, opts):
    """A raster, or point clouds gridded (``path`` a list of cloud files: read as one, as tinsmith.read does)."""
    return read_heightfield(path, statistic=opts["statistic"], **reader_options(opts))


def load_source(path, opts, record):
    """The input of the method: a heightfield, or a mesh when the file holds one and the method takes meshes."""
    if isinstance(path, list) or reader_for(path).kind != "mesh":
        return load_heightfield(path, opts)
    if record.input in ("heightfield", "elevation"):
        takes_meshes = ", ".join(m.name for m in methods() if m.input in ("mesh", "surface"))
        raise InvalidInputError(
            f"{str(path)!r} is a mesh, but method {record.name!r} takes a raster or a point cloud; "
            f"methods that take meshes: {takes_meshes}"
        )
    return read(path, **reader_options(opts))


def cloud_files(inputs, sample=None) -> list | None:
    """The files of point-cloud inputs (several files, folders, globs), or None for one file of another kind."""
    if inputs and sample:
        raise click.UsageError("give an input file or --sample, not both")
    return cloud_inputs(inputs)


def label_of(files) -> str:
    return str(files[0]) if len(files) == 1 else f"{len(files)} files ({files[0].name}, ...)"


def describe_source(source, label) -> str:
    if isinstance(source, core.Heightfield):
        rows, cols = source.shape
        return f"{label}: {rows:,} x {cols:,} = {source.n_cells:,} cells ({source.n_valid:,} valid)"
    if isinstance(source, core.PointCloud):
        return f"{label}: {len(source):,} points"
    return f"{label}: a mesh of {source.n_vertices:,} vertices, {source.n_triangles:,} triangles"


def parse_levels(raw: str, kind, flag: str) -> list:
    try:
        values = [kind(v) for v in raw.replace(" ", "").split(",") if v]
    except ValueError:
        raise click.BadParameter(f"{flag} takes numbers separated by commas, e.g. 20,5,1; got {raw!r}") from None
    if not values:
        raise click.BadParameter(f"{flag} takes at least one level")
    repeated = sorted({v for v in values if values.count(v) > 1})
    if repeated:
        raise click.BadParameter(f"{flag} lists the level {repeated[0]:g} more than once ({raw}); give each level once")
    return values


#: The validators' messages about a value (tinsmith._checks): ``NAME must be ...``.
_OPTION_MESSAGE = re.compile(r"^[A-Za-z_][\w\[\]]* must ")


@contextlib.contextmanager
def naming(path, geometry=None):
    """Name the input in the errors its data causes (no points, no area, a bad mesh) that do not name it yet.

    ``geometry`` maps option names (``breaklines``) to the files they came
    from: an error about them names that file.  Option errors are left as
    they are: they name the option, not the file.
    """
    files = []
    if isinstance(path, list):  # several point-cloud files read as one
        files, path = path, label_of(path)
    try:
        yield
    except InvalidOptionError:
        raise
    except InvalidInputError as exc:
        text = str(exc)
        if text.startswith("'") or str(path) in text or Path(str(path)).name in text:  # names a file already
            raise
        if any(repr(str(f)) in text for f in files):  # names one of the files read ("clouds 'a.las' and ...")
            raise
        if _OPTION_MESSAGE.match(text):  # "mu must be a finite number > 1, got 0": about an option, not the file
            raise
        about = next((f for name, f in (geometry or {}).items() if text.startswith(name)), path)
        raise type(exc)(f"{str(about)!r}: {text}") from exc
