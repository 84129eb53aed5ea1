"""Error helpers shared by the readers and writers: every message names the file."""

from __future__ import annotations

import contextlib
import functools
from pathlib import Path

from ..errors import FormatError, InvalidInputError, InvalidOptionError, TinsmithError

__all__ = ["file_named_errors", "first_line", "format_error", "option_value", "with_file_name"]


def first_line(exc: BaseException) -> str:
    """First line of a library's message (of its cause when it has one, as rasterio's
    "see previous exception" errors do); the exception's type when it says nothing."""
    source = exc.__cause__ or exc
    lines = str(source).strip().splitlines()
    return lines[0] if lines else type(source).__name__


@contextlib.contextmanager
def file_named_errors(path):
    """Re-raise tinsmith errors from the block as the same class, ``"'path': message"``.

    A message that already names the file is left as it is.
    """
    try:
        yield
    except TinsmithError as exc:
        name = repr(str(path))
        if name in str(exc):
            raise
        raise type(exc)(f"{name}: {exc}") from exc


def with_file_name(func):
    """Decorate a reader ``func(path, **options)`` with :func:`file_named_errors`."""

    @functools.wraps(func)
    def wrapper(path, **options):
        with file_named_errors(path):
            return func(Path(path), **options)

    return wrapper


def format_error(path, what: str, exc: BaseException) -> FormatError:
    """A one-line :class:`FormatError` for a library failure: ``cannot read 'path' as <what>: ...``.

    The detail is the first line of the library's message (of its cause when
    it has one, as rasterio's "see previous exception" errors do).
    """
    return FormatError(f"cannot read {str(path)!r} as {what}: {first_line(exc)}")


def option_value(check, *args, **kwargs):
    """Run a :mod:`tinsmith._checks` validator on a reader option.

    Its :class:`InvalidInputError` becomes an :class:`InvalidOptionError`.
    """
    try:
        return check(*args, **kwargs)
    except InvalidOptionError:
        raise
    except InvalidInputError as exc:
        raise InvalidOptionError(str(exc)) from None
