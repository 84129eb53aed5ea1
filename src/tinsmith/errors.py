"""Errors raised by tinsmith.

Every class derives from :class:`TinsmithError` and also from the builtin a
Python user would catch for that kind of failure, so ``except ValueError`` and
``except OSError`` keep working.  Messages name the parameter or file, what was
expected and what came.
"""

from __future__ import annotations


class TinsmithError(Exception):
    """Root of every error tinsmith raises on purpose.

    Examples
    --------
    >>> import tinsmith
    >>> try:
    ...     tinsmith.simplify(tinsmith.sample("st-helens"), method="grid", max_error=1.0)
    ... except tinsmith.TinsmithError as error:  # every error tinsmith raises on purpose
    ...     print(type(error).__name__)
    InvalidOptionError
    """


class InvalidInputError(TinsmithError, ValueError):
    """A parameter or an input array is not what the function expects.

    Examples
    --------
    >>> import numpy as np
    >>> import tinsmith
    >>> try:
    ...     tinsmith.Heightfield(np.zeros((1, 5)), cell_size=1.0)
    ... except ValueError as error:  # an InvalidInputError is a ValueError too
    ...     print(type(error).__name__)
    InvalidInputError
    """


class NoDataError(InvalidInputError):
    """The input holds no usable data (all nodata, no points of a class, ...).

    Examples
    --------
    >>> import numpy as np
    >>> import tinsmith
    >>> tinsmith.Heightfield(np.full((3, 3), -9999.0), cell_size=1.0, nodata=-9999.0)
    Traceback (most recent call last):
    ...
    tinsmith.errors.NoDataError: every cell of the heightfield is nodata
    """


class InvalidMeshError(InvalidInputError):
    """A triangle mesh breaks one of the rules of :class:`tinsmith.TerrainMesh`.

    Examples
    --------
    >>> import tinsmith
    >>> flipped = tinsmith.TerrainMesh([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 2, 1]])  # clockwise
    >>> flipped.validate()
    Traceback (most recent call last):
    ...
    tinsmith.errors.InvalidMeshError: ...
    """


class UnknownMethodError(InvalidInputError):
    """The method name is not in the registry.

    Examples
    --------
    >>> import tinsmith
    >>> tinsmith.simplify(tinsmith.sample("st-helens"), method="marching")
    Traceback (most recent call last):
    ...
    tinsmith.errors.UnknownMethodError: unknown method 'marching'; choose one of: ...
    """


class InvalidOptionError(InvalidInputError):
    """An option is unknown to the chosen method or has a bad value.

    Examples
    --------
    >>> import tinsmith
    >>> tinsmith.subsample(tinsmith.sample("st-helens"), stride=4)
    Traceback (most recent call last):
    ...
    tinsmith.errors.InvalidOptionError: method 'subsample' has no option 'stride'; its options are: step, ...
    """


class FileError(TinsmithError, OSError):
    """A file cannot be found, read or written (missing folder, permissions, ...).

    Examples
    --------
    >>> import tempfile
    >>> import tinsmith
    >>> with tempfile.TemporaryDirectory() as folder:
    ...     try:
    ...         tinsmith.read(folder)  # an empty folder: no point cloud in it
    ...     except OSError as error:  # a FileError is an OSError too
    ...         print(type(error).__name__)
    FileError
    """


class FormatError(FileError):
    """A file's content is not in the format its name implies, or is damaged.

    Examples
    --------
    >>> import tempfile
    >>> from pathlib import Path
    >>> import tinsmith
    >>> with tempfile.TemporaryDirectory() as folder:
    ...     path = Path(folder) / "broken.ply"
    ...     _ = path.write_text("not a mesh")
    ...     try:
    ...         tinsmith.read(path)
    ...     except tinsmith.FormatError as error:
    ...         print(type(error).__name__)
    FormatError
    """


class InputNotFoundError(FileError, FileNotFoundError):
    """An input file does not exist.

    Examples
    --------
    >>> import tinsmith
    >>> try:
    ...     tinsmith.read("no-such-dem.tif")
    ... except FileNotFoundError as error:  # an InputNotFoundError is a FileNotFoundError too
    ...     print(error)
    input file 'no-such-dem.tif' does not exist
    """


class ResourceError(TinsmithError, MemoryError):
    """A step would need more memory than this process may use; the message gives both and what to do."""


class UnsupportedFormatError(TinsmithError, ValueError):
    """No reader or writer is registered for this file suffix.

    Examples
    --------
    >>> import numpy as np
    >>> import tinsmith
    >>> mesh = tinsmith.grid(tinsmith.Heightfield(np.zeros((3, 3)), cell_size=1.0))
    >>> tinsmith.write(mesh, "mesh.docx")
    Traceback (most recent call last):
    ...
    tinsmith.errors.UnsupportedFormatError: cannot write 'mesh.docx': unsupported output suffix .docx; use one of ...
    """


class TinsmithWarning(UserWarning):
    """Something the user should know, where tinsmith goes on (land use outside the DEM, ...)."""


class TinsmithNote(UserWarning):
    """Something tinsmith did for the user that changes no result they asked for (vectors reprojected, ...):
    the command line shows it as one ``tinsmith: note:`` line."""


class MissingDependencyError(TinsmithError, ImportError):
    """An optional dependency is needed; the message names the extra to install.

    Examples
    --------
    >>> import tinsmith
    >>> tinsmith.errors.require("lasreader", "lidar", "reading LAS")  # names the extra that installs it
    Traceback (most recent call last):
    ...
    tinsmith.errors.MissingDependencyError: reading LAS needs the optional package 'lasreader': pip install 'tinsmith[lidar]'
    >>> issubclass(tinsmith.MissingDependencyError, ImportError)
    True
    """


def require(module: str, extra: str, purpose: str):
    """Import an optional module or raise :class:`MissingDependencyError`.

    Parameters
    ----------
    module : str
        Importable module name, e.g. ``"laspy"``.
    extra : str
        The tinsmith extra that installs it, e.g. ``"lidar"``.
    purpose : str
        What it is needed for, e.g. ``"reading LAS/LAZ files"``.
    """
    import importlib

    try:
        return importlib.import_module(module)
    except ImportError as exc:  # pragma: no cover - exercised only without extras
        raise MissingDependencyError(
            f"{purpose} needs the optional package {module!r}: "
            f"pip install 'tinsmith[{extra}]'"
        ) from exc
