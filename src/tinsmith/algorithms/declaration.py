"""What a method is made of, as data: its options (:class:`Option`) and its record (:class:`Declaration`).

This module sits below both :mod:`.catalogue` (which declares the built-in
methods with these classes) and :mod:`.registry` (which lists the
declarations and runs the methods), so that neither imports the other's
definitions back.  It imports nothing but the checks of option values.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from .. import _checks
from ..errors import InvalidInputError, InvalidOptionError

__all__ = ["GEOMETRY_KINDS", "INPUT_TYPES", "STOP_RULES", "Declaration", "Option", "input_words", "stop_rules"]

#: Names of the stop rules every method takes in its signature; one it cannot honour is refused.
STOP_RULES = ("max_error", "max_vertices", "max_triangles")

#: input kind -> the names of the data-model classes a method of that kind takes (resolved when it runs)
INPUT_TYPES = {
    "heightfield": ("Heightfield",),
    "mesh": ("TerrainMesh",),
    "surface": ("Heightfield", "TerrainMesh"),
    "elevation": ("Heightfield", "PointCloud"),
    "points": ("PointCloud",),
}

#: Option kinds whose values are files on the command line: geometries (world coordinates in the API, a
#: vector file on the command line) and rasters (a Heightfield or an array in the API, a raster file there).
GEOMETRY_KINDS = ("lines", "points", "polygons", "regions", "raster")

#: input kind -> how an option limited to it says so in help texts and errors
_KIND_WORDS = {"heightfield": "rasters", "points": "point clouds", "mesh": "meshes"}


def input_words(input: str) -> str:
    """The classes an input kind takes, in words: ``"Heightfield or PointCloud"``."""
    return " or ".join(INPUT_TYPES[input])


@dataclass(frozen=True)
class Option:
    """A typed, validated, documented option of a method.

    Parameters
    ----------
    name : str
        Python keyword; the CLI flag is ``--name-with-dashes``.
    type : {float, int, bool, str, object}
        Value type; ``object`` for geometry inputs (see ``kind``), which the
        method itself checks.
    default : Any
        Value when not given (``None`` means "not set").
    doc : str
        One sentence for the docs and ``--help``; give the unit.
    minimum, maximum : float, optional
        Bounds for numbers; ``exclusive_min`` makes the lower bound strict.
    choices : tuple of str, optional
        Allowed values for strings.
    kind : {"value", "lines", "points", "polygons", "regions", "raster"}
        "lines", "points" and "polygons" mark geometry inputs: arrays or
        shapely geometries in world coordinates in the API, a vector file on
        the command line; "regions" polygons with attributes (``max_area``,
        ``name``): (polygon, max_area, name) items in the API; "raster" a
        grid on the input's cells: a Heightfield or an array in the API, a
        raster file on the command line.
    input : {"heightfield", "points"}, optional
        The one kind of input the option applies to, for a method that takes
        several (``greedy``: rasters and point clouds); given with another
        kind it is refused.  None: every input the method takes.
    replaced_by : str, optional
        The option is a deprecated name of this keyword (another option or a
        stop rule): its value is checked under the old name, then passed on
        under the new one with a :class:`DeprecationWarning`.
    """

    name: str
    type: type
    default: Any
    doc: str
    minimum: float | None = None
    maximum: float | None = None
    exclusive_min: bool = False
    choices: tuple[str, ...] | None = None
    kind: str = "value"
    input: str | None = None
    replaced_by: str | None = None

    def validate(self, value):
        """``value`` checked (and numbers made float or int); :class:`InvalidOptionError` names the option."""
        try:
            return self._validate(value)
        except InvalidInputError as exc:
            if isinstance(exc, InvalidOptionError):
                raise
            raise InvalidOptionError(str(exc)) from None

    def _validate(self, value):
        if value is None or self.type is object:
            return value
        if self.type is float:
            return _checks.number(
                self.name, value, minimum=self.minimum, exclusive_min=self.exclusive_min, maximum=self.maximum
            )
        if self.type is int:
            return _checks.integer(self.name, value, minimum=self.minimum, maximum=self.maximum)
        if self.type is bool:
            if not isinstance(value, bool):
                raise InvalidOptionError(f"{self.name} must be True or False, got {value!r}")
            return value
        if self.type is str:
            if not isinstance(value, str):
                raise InvalidOptionError(f"{self.name} must be a string, got {value!r}")
            return _checks.choice(self.name, value, self.choices) if self.choices else value
        raise TypeError(f"option {self.name!r} has an unsupported type {self.type!r}")  # pragma: no cover

    def describe(self) -> str:
        """The doc sentence with the input it applies to, the range and default, for help texts."""
        if self.replaced_by:
            return f"deprecated: use {self.replaced_by} (the same value)"
        parts = [f"{_KIND_WORDS[self.input]}: {self.doc}" if self.input else self.doc]
        if self.choices:
            parts.append("one of " + ", ".join(self.choices))
        if self.default is not None:
            parts.append(f"default {self.default!r}")
        return "; ".join(parts)

    def applies_to(self, kind: str | None) -> bool:
        """Whether the option applies to an input of ``kind`` ("heightfield", "points", "mesh")."""
        return self.input is None or kind is None or self.input == kind


@dataclass(frozen=True)
class Declaration:
    """A method as declared in :mod:`.catalogue`: everything but its code, which lives in ``module``.

    ``legacy`` names keywords the public function still takes for one
    release (they reach the method's code as given, with a
    :class:`DeprecationWarning` that says what to use instead); they are
    no options: no flag, no entry in the signature.  A ``deprecated``
    method (its text says what to use instead) still runs by name, with a
    :class:`DeprecationWarning`, but :func:`tinsmith.methods` no longer
    lists it.
    """

    name: str
    module: str
    description: str
    options: tuple[Option, ...] | list[Option] = ()
    stop_rules: bool | tuple[str, ...] = True  #: True: every rule of STOP_RULES; or the ones honoured
    input: str = "heightfield"
    paper: str = ""
    exact_budget: bool = False  #: max_vertices is the exact vertex count of the result, not a ceiling
    legacy: Mapping[str, str] = field(default_factory=dict)  #: deprecated keyword -> what to use instead
    deprecated: str = ""  #: non-empty: the method is deprecated; what to use instead


def stop_rules(given) -> tuple[str, ...]:
    """The stop rules a method honours: True means all of STOP_RULES, False none."""
    if given is True:
        return STOP_RULES
    rules = tuple(given or ())
    unknown = [r for r in rules if r not in STOP_RULES]
    if unknown:
        raise ValueError(f"unknown stop rule(s) {unknown}; choose from {STOP_RULES}")
    return rules
