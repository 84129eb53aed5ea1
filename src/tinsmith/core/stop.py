"""Stop rules shared by every refining or decimating method."""

from __future__ import annotations

from dataclasses import dataclass

from .. import _checks

__all__ = ["StopCriteria", "default_max_error"]


@dataclass(frozen=True)
class StopCriteria:
    """When a refining or decimating method stops; the first rule reached wins.

    Parameters
    ----------
    max_error : float, optional
        Largest vertical error allowed, in z units (>= 0).
    max_vertices : int, optional
        Largest number of mesh vertices (>= 3).
    max_triangles : int, optional
        Largest number of triangles (>= 1).

    Examples
    --------
    >>> import tinsmith
    >>> stop = tinsmith.StopCriteria(max_error=0.5, max_vertices=1000)
    >>> stop.reached(error=2.0, n_vertices=1000, n_triangles=1900)
    'max_vertices'
    >>> stop.reached(error=0.4, n_vertices=10, n_triangles=12)
    'max_error'
    >>> print(stop.reached(error=2.0, n_vertices=10, n_triangles=12))
    None
    """

    max_error: float | None = None
    max_vertices: int | None = None
    max_triangles: int | None = None

    def __post_init__(self):
        if self.max_error is not None:
            object.__setattr__(self, "max_error", _checks.number("max_error", self.max_error, minimum=0.0))
        if self.max_vertices is not None:
            object.__setattr__(self, "max_vertices", _checks.integer("max_vertices", self.max_vertices, minimum=3))
        if self.max_triangles is not None:
            object.__setattr__(
                self, "max_triangles", _checks.integer("max_triangles", self.max_triangles, minimum=1)
            )

    @property
    def is_set(self) -> bool:
        """True when at least one rule is given."""
        return any(v is not None for v in (self.max_error, self.max_vertices, self.max_triangles))

    def reached(self, error: float, n_vertices: int, n_triangles: int) -> str | None:
        """Name of the first rule that is met, or None to go on.

        ``max_error`` is met when ``error <= max_error``; the count rules when the
        next step would exceed them (``n >= max``).
        """
        if self.max_error is not None and error <= self.max_error:
            return "max_error"
        if self.max_vertices is not None and n_vertices >= self.max_vertices:
            return "max_vertices"
        if self.max_triangles is not None and n_triangles >= self.max_triangles:
            return "max_triangles"
        return None

    def counts_fit(self, n_vertices: int, n_triangles: int) -> bool:
        """True when a mesh of these counts keeps within the count rules (the error rule is not looked at)."""
        return (self.max_vertices is None or n_vertices <= self.max_vertices) and (
            self.max_triangles is None or n_triangles <= self.max_triangles
        )

    def as_dict(self) -> dict:
        return {"max_error": self.max_error, "max_vertices": self.max_vertices, "max_triangles": self.max_triangles}


def default_max_error(hf) -> float:
    """The error bound of a grid method given no stop rule: 1/1000 of the heightfield's height range."""
    lo, hi = hf.z_range
    return (hi - lo) / 1000.0
