"""The data a :class:`~tinsmith.core.TerrainMesh` carries beside its vertices and triangles.

:class:`Attributes` holds named arrays over one kind of element (vertices or
triangles) and checks that each has one row per element, as trimesh keeps
its face and vertex attributes.  The other helpers here check the edge data
(constrained edges, node strings) and the code tables (names and per-code
values of a coded attribute), and keep the ``info`` keys of tinsmith 0.1
readable for one release.
"""

from __future__ import annotations

import warnings
from collections.abc import Iterator, Mapping, MutableMapping

import numpy as np

from ..errors import InvalidMeshError

__all__ = ["Attributes"]


class Attributes(MutableMapping):
    """Arrays over the vertices or the triangles of a mesh, by name.

    The first dimension of every array is the number of elements of the
    mesh (checked when an array is set, and by :meth:`TerrainMesh.check`
    if the mesh's arrays are replaced later); any dtype and any further
    dimensions are allowed.  Arrays are stored as given (no copy, no cast).

    Examples
    --------
    >>> import numpy as np
    >>> from tinsmith.core import TerrainMesh
    >>> mesh = TerrainMesh([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]])
    >>> mesh.triangle_attributes["region"] = np.array([1])
    >>> mesh.triangle_attributes["region"] = np.array([1, 2])
    Traceback (most recent call last):
    ...
    tinsmith.errors.InvalidMeshError: triangle attribute 'region' has 2 rows; the mesh has 1 triangles
    """

    __slots__ = ("_mesh", "_element", "_arrays")

    def __init__(self, mesh, element: str, arrays: Mapping | None = None):
        self._mesh = mesh
        self._element = element  # "vertex" or "triangle"
        self._arrays: dict[str, np.ndarray] = {}
        for name, value in (arrays or {}).items():
            self[name] = value

    @property
    def size(self) -> int:
        """The number of elements: rows every array must have."""
        return len(self._mesh.vertices if self._element == "vertex" else self._mesh.triangles)

    def _checked(self, name, value) -> np.ndarray:
        if not isinstance(name, str) or not name:
            raise InvalidMeshError(f"{self._element} attribute names are non-empty strings, got {name!r}")
        a = np.asarray(value)
        if a.ndim == 0:
            raise InvalidMeshError(f"{self._element} attribute {name!r} must be an array with one row per "
                                   f"{self._element}, got a scalar")
        if len(a) != self.size:
            raise InvalidMeshError(f"{self._element} attribute {name!r} has {len(a)} rows; the mesh has {self.size} "
                                   f"{self._noun}")
        return a

    def __setitem__(self, name: str, value) -> None:
        self._arrays[name] = self._checked(name, value)

    def __getitem__(self, name: str) -> np.ndarray:
        return self._arrays[name]

    def __delitem__(self, name: str) -> None:
        del self._arrays[name]

    def __iter__(self) -> Iterator[str]:
        return iter(self._arrays)

    def __len__(self) -> int:
        return len(self._arrays)

    def __repr__(self) -> str:
        inner = ", ".join(f"{k!r}: {v.dtype}{list(v.shape)}" for k, v in self._arrays.items())
        return f"Attributes({self._element}, {{{inner}}})"

    @property
    def _noun(self) -> str:
        return "vertices" if self._element == "vertex" else "triangles"

    def problems(self) -> list[str]:
        """Sentences for every array whose length is no longer the element count (the mesh was changed)."""
        n = self.size
        return [f"{self._element} attribute {k!r} has {len(v)} rows; the mesh has {n} {self._noun}"
                for k, v in self._arrays.items() if len(v) != n]

    def taken(self, index) -> dict[str, np.ndarray]:
        """Every array's rows at ``index`` (a mask or indices), as a plain dict."""
        return {k: v[index] for k, v in self._arrays.items()}

    def copied(self) -> dict[str, np.ndarray]:
        return {k: v.copy() for k, v in self._arrays.items()}


def check_edges(value, n_vertices: int) -> np.ndarray:
    """``value`` as an (E, 2) int64 array of vertex pairs, each index in range."""
    if value is None:
        return np.empty((0, 2), np.int64)
    e = np.asarray(value)
    if e.size == 0:
        return np.empty((0, 2), np.int64)
    if e.ndim != 2 or e.shape[1] != 2:
        raise InvalidMeshError(f"constrained_edges must have shape (E, 2), got {e.shape}")
    if not np.issubdtype(e.dtype, np.integer):
        raise InvalidMeshError(f"constrained_edges must hold integer vertex indices, got dtype {e.dtype}")
    _in_range("constrained_edges", e, n_vertices)
    return np.ascontiguousarray(e, dtype=np.int64)


def check_node_strings(value, n_vertices: int) -> dict[str, np.ndarray]:
    """``value`` as {name: 1-D int64 vertex indices in order}, each index in range."""
    out = {}
    for name, ids in (value or {}).items():
        a = np.asarray(ids)
        if not isinstance(name, str) or a.ndim != 1 or (a.size and not np.issubdtype(a.dtype, np.integer)):
            raise InvalidMeshError(f"node string {name!r} must be named by a string and hold a 1-D array of "
                                   f"integer vertex indices, got {a.dtype}{list(a.shape)}")
        _in_range(f"node string {name!r}", a, n_vertices)
        out[name] = a.astype(np.int64)
    return out


def _in_range(what: str, a: np.ndarray, n: int) -> None:
    if a.size and (a.min() < 0 or a.max() >= n):
        raise InvalidMeshError(f"{what} index vertices 0..{n - 1}, got indices {a.min()}..{a.max()}")


def check_labels(value) -> dict[str, dict[int, str]]:
    """``value`` as {attribute: {code: name}}."""
    out = {}
    for attr, names in (value or {}).items():
        if not isinstance(attr, str) or not isinstance(names, Mapping):
            raise InvalidMeshError(f"labels map an attribute name to {{code: name}}, got {attr!r}: {names!r}")
        out[attr] = {int(code): str(name) for code, name in names.items()}
    return out


def check_tables(value) -> dict[str, dict[str, np.ndarray]]:
    """``value`` as {attribute: {column: 1-D array over the codes 0, 1, ...}}."""
    out = {}
    for attr, columns in (value or {}).items():
        if not isinstance(attr, str) or not isinstance(columns, Mapping):
            raise InvalidMeshError(f"tables map an attribute name to {{column: array}}, got {attr!r}: {columns!r}")
        out[attr] = {}
        for column, values in columns.items():
            a = np.asarray(values)
            if a.ndim != 1:
                raise InvalidMeshError(f"table column {attr}.{column} must be 1-D (one value per code), "
                                       f"got shape {a.shape}")
            out[attr][str(column)] = a
    return out


# -- the info keys of tinsmith 0.1 -----------------------------------------------------------------------------

#: The per-element keys ``info`` held in tinsmith 0.1 and the typed field each moved to.
LEGACY_KEYS = {
    "triangle_region": "triangle_attributes['region']",
    "triangle_kind": "triangle_attributes['kind']",
    "triangle_patch": "triangle_attributes['patch']",
    "triangle_building": "triangle_attributes['building']",
    "triangle_face": "triangle_attributes['face']",
    "site_kind": "vertex_attributes['site']",
    "constrained_edges": "constrained_edges",
    "node_strings": "node_strings",
    "region_names": "labels['region']",
    "patch_names": "labels['patch']",
    "building_height": "tables['building']['height']",
}

#: The first code of the name lists of 0.1 (region 0 is outside every region; patch 0 is the ground).
_FIRST_CODE = {"region_names": ("region", 1), "patch_names": ("patch", 0)}
_ATTRIBUTES = {"triangle_region": ("triangle", "region"), "triangle_kind": ("triangle", "kind"),
               "triangle_patch": ("triangle", "patch"), "triangle_building": ("triangle", "building"),
               "triangle_face": ("triangle", "face"), "site_kind": ("vertex", "site")}


def _warn(key: str, stacklevel: int = 4) -> None:
    warnings.warn(f"mesh.info[{key!r}] is deprecated and goes in the next release: use mesh.{LEGACY_KEYS[key]}",
                  DeprecationWarning, stacklevel=stacklevel)


def _legacy_get(mesh, key: str):
    """The value ``info[key]`` had in 0.1, read from its typed field; KeyError when the mesh has none."""
    if key in _ATTRIBUTES:
        element, name = _ATTRIBUTES[key]
        return (mesh.vertex_attributes if element == "vertex" else mesh.triangle_attributes)[name]
    if key == "constrained_edges":
        if not len(mesh.constrained_edges):
            raise KeyError(key)
        return mesh.constrained_edges
    if key == "node_strings":
        if not mesh.node_strings:
            raise KeyError(key)
        return mesh.node_strings
    if key in _FIRST_CODE:
        attr, first = _FIRST_CODE[key]
        names = mesh.labels[attr]
        return [names.get(code, "") for code in range(first, max(names) + 1)] if names else []
    return mesh.tables["building"]["height"]


def legacy_set(mesh, key: str, value) -> None:
    """Put what 0.1 stored as ``info[key]`` into its typed field."""
    if key in _ATTRIBUTES:
        element, name = _ATTRIBUTES[key]
        (mesh.vertex_attributes if element == "vertex" else mesh.triangle_attributes)[name] = value
    elif key == "constrained_edges":
        mesh.constrained_edges = value
    elif key == "node_strings":
        mesh.node_strings = value
    elif key in _FIRST_CODE:
        attr, first = _FIRST_CODE[key]
        mesh.labels[attr] = {first + k: str(name) for k, name in enumerate(value)}
    else:
        mesh.tables.setdefault("building", {})["height"] = np.asarray(value)


class Info(dict):
    """``mesh.info``: the run's metadata, which still answers the per-element keys of 0.1 with a DeprecationWarning.

    Those keys are not stored here (iterating, ``len`` and ``dict(info)``
    see the metadata only); reading or setting one goes to the mesh's typed
    field.
    """

    def __init__(self, mesh, items=()):
        super().__init__()
        self._mesh = mesh
        self.update(items)

    def _read(self, key, stacklevel: int):
        _warn(key, stacklevel)
        return _legacy_get(self._mesh, key)

    def __getitem__(self, key):
        if key in LEGACY_KEYS and not dict.__contains__(self, key):
            return self._read(key, 4)
        return dict.__getitem__(self, key)

    def get(self, key, default=None):
        if key not in LEGACY_KEYS or dict.__contains__(self, key):
            return dict.get(self, key, default)
        try:
            return self._read(key, 4)
        except KeyError:
            return default

    def __contains__(self, key) -> bool:
        if dict.__contains__(self, key) or key not in LEGACY_KEYS:
            return dict.__contains__(self, key)
        try:
            _legacy_get(self._mesh, key)
        except KeyError:
            return False
        return True

    def __setitem__(self, key, value) -> None:
        if key in LEGACY_KEYS:
            _warn(key, 3)
            legacy_set(self._mesh, key, value)
        else:
            dict.__setitem__(self, key, value)

    def update(self, *args, **kwargs) -> None:
        items = dict(*args, **kwargs)
        if LEGACY_KEYS.keys() & items.keys():
            for key, value in items.items():
                self[key] = value
        else:
            dict.update(self, items)

    def setdefault(self, key, default=None):
        if key not in self:
            self[key] = default
        return self[key]

    def copy(self) -> dict:
        return dict(self)
