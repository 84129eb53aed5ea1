"""Errors raised by tinsmith.

Every class derives from :class:`TinsmithError` and also from the builtin a
Python user would catch for that kind of failure, so ``except ValueError`` and
``except OSError`` keep working.  Messages name the parameter or file, what was
expected and what came.
"""

from __future__ import annotations


class TinsmithError(Exception):
    """Root of every error tinsmith raises on purpose."""


class InvalidInputError(TinsmithError, ValueError):
    """A parameter or an input array is not what the function expects."""


class NoDataError(InvalidInputError):
    """The input holds no usable data (all nodata, no points of a class, ...)."""


class InvalidMeshError(InvalidInputError):
    """A triangle mesh breaks one of the rules of :class:`tinsmith.TerrainMesh`."""


class UnknownMethodError(InvalidInputError):
    """The method name is not in the registry."""


class InvalidOptionError(InvalidInputError):
    """An option is unknown to the chosen method or has a bad value."""


class FileError(TinsmithError, OSError):
    """A file cannot be found, read or written (missing folder, permissions, ...)."""


class FormatError(FileError):
    """A file's content is not in the format its name implies, or is damaged."""


class InputNotFoundError(FileError, FileNotFoundError):
    """An input file does not exist."""


class ResourceError(TinsmithError, MemoryError):
    """A step would need more memory than this process may use; the message gives both and what to do."""


class UnsupportedFormatError(TinsmithError, ValueError):
    """No reader or writer is registered for this file suffix."""


class TinsmithWarning(UserWarning):
    """Something the user should know, where tinsmith goes on (land use outside the DEM, ...)."""


class TinsmithNote(UserWarning):
    """Something tinsmith did for the user that changes no result they asked for (vectors reprojected, ...):
    the command line shows it as one ``tinsmith: note:`` line."""


class MissingDependencyError(TinsmithError, ImportError):
    """An optional dependency is needed; the message names the extra to install."""


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
