"""Small validators shared by the public boundary (data model, registry, io).

Each returns the cleaned value or raises :class:`InvalidInputError` with a
message of the form ``"<name> must be <expected>, got <value>"``.
"""

from __future__ import annotations

import math
import numbers
import os

from .errors import InvalidInputError


def _show(value) -> str:
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


def number(name: str, value, *, minimum=None, exclusive_min=False, maximum=None) -> float:
    """A finite real number within optional bounds."""
    bound = ""
    if minimum is not None:
        bound = f" {'>' if exclusive_min else '>='} {minimum:g}"
    if maximum is not None:
        bound += f"{' and' if bound else ''} <= {maximum:g}"
    expected = f"a finite number{bound}"
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise InvalidInputError(f"{name} must be {expected}, got {_show(value)}")
    value = float(value)
    if (
        not math.isfinite(value)
        or (minimum is not None and (value <= minimum if exclusive_min else value < minimum))
        or (maximum is not None and value > maximum)
    ):
        raise InvalidInputError(f"{name} must be {expected}, got {value!r}")
    return value


def integer(name: str, value, *, minimum=None, maximum=None) -> int:
    """A whole number within optional bounds (floats with no fraction are accepted)."""
    bound = f" >= {minimum}" if minimum is not None else ""
    if maximum is not None:
        bound += f"{' and' if bound else ''} <= {maximum}"
    expected = f"a whole number{bound}"
    if isinstance(value, bool):
        raise InvalidInputError(f"{name} must be {expected}, got {_show(value)}")
    if isinstance(value, numbers.Integral) or (
            isinstance(value, numbers.Real) and math.isfinite(value) and float(value).is_integer()):
        value = int(value)
    else:
        raise InvalidInputError(f"{name} must be {expected}, got {_show(value)}")
    if (minimum is not None and value < minimum) or (maximum is not None and value > maximum):
        raise InvalidInputError(f"{name} must be {expected}, got {value}")
    return value


def choice(name: str, value, choices) -> str:
    """One of a fixed set of strings."""
    if value not in choices:
        listed = ", ".join(repr(c) for c in choices)
        raise InvalidInputError(f"{name} must be one of {listed}, got {_show(value)}")
    return value


def workers(value, name: str = "workers") -> int:
    """A number of threads or processes: a whole number >= 1, or None for every core."""
    if value is None:
        return os.cpu_count() or 1
    return integer(name, value, minimum=1)
