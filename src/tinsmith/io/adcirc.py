"""ADCIRC's grid and boundary file (``fort.14``), with its open and land boundary segments.

The layout is the one of ADCIRC's manual ("ADCIRC Grid and Boundary
Information File"): a header line (``AGRID``), ``NE NP``, one ``JN X Y DP``
line per node, one ``JE 3 N1 N2 N3`` line per element (1-based, counter-
clockwise seen from above), then ``NOPE`` / ``NETA`` and the open
(elevation-specified) segments, each ``NVDLL 0`` and its node ids, then
``NBOU`` / ``NVEL`` and the land (normal-flow) segments, each ``NVELL IBTYPE``
and its node ids.

Depth: ADCIRC's ``DP`` is positive *downward* from the datum, so a node's
depth is ``-z`` (a terrain at 120 m above the datum has ``DP = -120``; the
sea bed 8 m below it ``DP = 8``).

Boundary segments, from the border of the mesh
(:func:`.boundaries.named_boundaries`) and ``mesh.node_strings``:

* a node string whose name starts with ``inflow``, ``outflow`` or ``open``
  (any case) becomes an open segment (``IBTYPEE`` 0, elevation specified);
  it must run along the border, and is written in the border's direction
  (the domain on the left);
* every other border edge is land: ``IBTYPE 20`` (external, no normal flow
  as a natural condition, free tangential slip: what ADCIRC's manual
  recommends over types 0 and 1) on a loop round the data, ``IBTYPE 21``
  (island) round a hole.  A loop with no open segment is one closed segment
  (its first node repeated at the end, as ADCIRC asks of a lake's shore and
  of islands); otherwise the land runs go from the end of one open segment
  to the start of the next (sharing those nodes), split also where another
  node string along the border starts or ends (so a named wall is a segment
  of its own; a run round a hole stays an island, 21);
* external segments come first, in the order round the outer loop, then the
  islands;
* node strings inside the mesh (breaklines) are not boundaries: left out.

ADCIRC files carry no CRS: it goes to a ``.prj`` sidecar (written by the
dispatcher).
"""

from __future__ import annotations

import numpy as np

from .._version import __version__
from ..core import TerrainMesh
from ..errors import InvalidInputError
from .boundaries import OPEN_PREFIXES, loop_area, named_boundaries, open_strings
from .mesh_formats import FLOAT, format_rows, write_text
from .registry import writer

__all__ = ["OPEN_PREFIXES", "LAND", "ISLAND", "fort14_segments", "write_fort14"]

#: IBTYPE of a land segment round the data (external, natural no-normal-flow, free slip) and round a hole.
LAND, ISLAND = 20, 21


def fort14_segments(mesh: TerrainMesh) -> tuple[list[np.ndarray], list[tuple[np.ndarray, int]]]:
    """(open segments, land segments with their IBTYPE) as 0-based vertex ids, in fort.14's order.

    See the module's description for the rules.

    Raises
    ------
    InvalidInputError
        An open node string with an edge that is not on the border of the
        mesh, or border edges claimed by two open node strings.
    """
    loops = named_boundaries(mesh)["outline"]
    strings = open_strings(mesh, loops)  # each runs along the border
    area = [loop_area(mesh.vertices, lp) for lp in loops]
    order = sorted(range(len(loops)), key=lambda k: area[k] < 0)  # round the data first, then the holes
    loops = [loops[k] for k in order]
    external = [area[k] >= 0 for k in order]
    # every directed border edge: (loop, position); a node string may run either way along it
    where = {}
    for k, lp in enumerate(loops):
        for i, (a, b) in enumerate(zip(lp[:-1].tolist(), lp[1:].tolist(), strict=True)):
            where[(a, b)] = (k, i)
    label = [np.full(len(lp) - 1, -1, np.int64) for lp in loops]
    names = list(strings)
    breaks: set[int] = set()
    for s, name in enumerate(names):
        ids = strings[name].tolist()
        for a, b in zip(ids[:-1], ids[1:], strict=True):
            k, i = where.get((a, b)) or where.get((b, a))
            if label[k][i] >= 0 and label[k][i] != s:
                raise InvalidInputError(
                    f"node strings {names[label[k][i]]!r} and {name!r} both claim the border edge {a}-{b}"
                )
            label[k][i] = s
    for name, ids in mesh.node_strings.items():
        if name in names or len(ids) < 2:
            continue
        pairs = zip(ids[:-1].tolist(), ids[1:].tolist(), strict=True)
        if all((a, b) in where or (b, a) in where for a, b in pairs):  # along the border: its ends split land
            breaks.update((int(ids[0]), int(ids[-1])))
    opened: dict[int, np.ndarray] = {}
    land: list[tuple[np.ndarray, int]] = []
    for lp, lab, ext in zip(loops, label, external, strict=True):
        if (lab < 0).all() and not breaks.intersection(lp[:-1].tolist()):
            land.append((lp, LAND if ext else ISLAND))
            continue
        for run, value in _runs(lp, lab, breaks):
            if value >= 0:
                opened[value] = run  # a node string is one path: one run
            else:
                land.append((run, LAND if ext else ISLAND))
    return [opened[s] for s in sorted(opened)], land


def _runs(loop: np.ndarray, label: np.ndarray, breaks: set[int]) -> list[tuple[np.ndarray, int]]:
    """The loop cut into runs of edges of one label, land runs also cut at the vertices of ``breaks``."""
    n = len(label)
    vertices = loop[:-1]

    def cut(i: int) -> bool:  # a run starts at edge i
        return label[i] != label[i - 1] or (label[i] < 0 and int(vertices[i]) in breaks)

    starts = [i for i in range(n) if cut(i)]
    if not starts:  # pragma: no cover - one open string round a whole loop
        return [(loop, int(label[0]))]
    runs = []
    for j, first in enumerate(starts):
        last = starts[(j + 1) % len(starts)]
        steps = (last - first) % n or n
        idx = (first + np.arange(steps + 1)) % n
        runs.append((vertices[idx], int(label[first])))
    return runs


@writer([".14", ".grd"], description="ADCIRC grid and boundary file (fort.14; depth = -z, positive down; open "
                                     "segments from inflow/outflow/open node strings, land and island segments "
                                     "round the rest of the border)", solver=True)
def write_fort14(mesh: TerrainMesh, path, *, grid=None) -> None:
    """Write ``mesh`` as ADCIRC's fort.14 (``fort.14``, ``*.14`` or ``*.grd``): see the module's description."""
    opened, land = fort14_segments(mesh)
    m, n = mesh.n_triangles, mesh.n_vertices
    name = " ".join(str(mesh.info.get("name") or "tin").split())
    depth = np.negative(mesh.vertices[:, 2]) + 0.0  # positive down; + 0.0: no "-0" for a height of 0
    parts = [
        f"{name} (tinsmith {__version__}; depth = -z)\n",
        f"{m} {n}\n",
        *format_rows(f"%d {FLOAT} {FLOAT} {FLOAT}\n", np.arange(1, n + 1), mesh.vertices[:, :2], depth),
        *format_rows("%d 3 %d %d %d\n", np.arange(1, m + 1), mesh.triangles + 1),
        f"{len(opened)} ! NOPE: open boundary segments\n",
        f"{sum(len(s) for s in opened)} ! NETA: open boundary nodes\n",
    ]
    for seg in opened:
        parts.append(f"{len(seg)} 0 ! NVDLL IBTYPEE\n")
        parts.extend(format_rows("%d\n", seg + 1))
    parts += [
        f"{len(land)} ! NBOU: land boundary segments\n",
        f"{sum(len(s) for s, _ in land)} ! NVEL: land boundary nodes\n",
    ]
    for seg, kind in land:
        parts.append(f"{len(seg)} {kind} ! NVELL IBTYPE\n")
        parts.extend(format_rows("%d\n", seg + 1))
    write_text(path, parts)
