"""TELEMAC's geometry file (SELAFIN: ``.slf``, ``.srf``, ``.selafin``) with its boundary-conditions file (``.cli``).

The geometry file is the layout of the TELEMAC documentation ("Binary file
format" of the TELEMAC-2D user manual): big-endian Fortran unformatted
sequential records, each ``int32`` byte count, payload, the same count:

1. the title: 72 characters and an 8-character format tag, ``SERAFIN `` for
   single precision (4-byte floats), ``SERAFIND`` for double (8-byte floats);
2. ``NBV(1) NBV(2)``: one linear variable, no quadratic one;
3. per variable its name and unit, 16 characters each: ``BOTTOM`` in ``M``;
4. ``IPARAM``, 10 integers: ``IPARAM(1) = 1``; ``IPARAM(3)``, ``IPARAM(4)``
   the x and y of the mesh's origin (whole coordinate units), which the
   coordinates below are relative to; ``IPARAM(7)`` (planes) 0: a 2-D mesh;
   ``IPARAM(8)``, ``IPARAM(9)`` 0: not a sub-domain of a parallel run (were
   either non-zero, the ``IPOBO`` record would be read as ``KNOLG``);
   ``IPARAM(10)`` 0: no date record;
5. ``NELEM NPOIN NDP 1`` with ``NDP = 3``;
6. ``IKLE``: the three 1-based nodes of each element in turn, counter-
   clockwise seen from above;
7. ``IPOBO``: per node its rank in the boundary numbering (1 to ``NPTFR``),
   0 inside;
8. ``X``, 9. ``Y``: relative to the origin of ``IPARAM``;
10. one time step: its time (0.0), then ``BOTTOM`` = z per node.

Precision: the origin is the floor of the smallest x and y, so that the
stored coordinates run from 0 to the mesh's extent.  They are single
precision (``SERAFIN``, what TELEMAC's geometry files usually are) when every
x, y and z survives the round trip to ``float32`` within 1 mm (1e-8 degree
for a geographic CRS); otherwise the whole file is double precision
(``SERAFIND``), in which x - origin is exact.  ``BOTTOM`` is ``z`` as it is
(``M``: the unit is the CRS's vertical one).  SELAFIN carries no CRS: it goes
to a ``.prj`` sidecar (written by the dispatcher).

The boundary-conditions file (same stem, suffix ``.cli``; the TELEMAC-2D user
manual, "The boundary conditions file") has one line per boundary node,
``LIHBOR LIUBOR LIVBOR HBOR UBOR VBOR AUBOR LITBOR TBOR ATBOR BTBOR N K``: the
conditions on the depth, the two velocity components and the tracer (2 a
solid wall, 4 free, 5 prescribed), their values (0.0 here: the steering file
or the liquid boundaries file gives them), ``N`` the node (1-based) and ``K``
its boundary rank (its ``IPOBO``).  The lines run in TELEMAC's boundary
order, the domain on the left: counter-clockwise round the outline, from its
south-west vertex (smallest x, then smallest y), then clockwise round each
hole, the largest first.  The codes, per node, from
``mesh.node_strings``:

* a node string whose name starts with ``outflow`` or ``open`` (any case):
  prescribed depth, free velocity: ``5 4 4``, tracer free (4);
* one whose name starts with ``inflow``: prescribed discharge (velocity),
  free depth: ``4 5 5``, tracer prescribed (5);
* every other border node: a solid wall, ``2 2 2``, tracer 2.

An open node string must run along the border; its nodes, both ends
included, take its codes (at a node two open strings share, the one listed
first in ``mesh.node_strings``).  Node strings inside the mesh are not
boundaries: left out.  A vertex on two border loops (where the mesh pinches)
cannot have one boundary rank: such a mesh is refused.
"""

from __future__ import annotations

import numpy as np

from .._version import __version__
from ..core import TerrainMesh
from ..errors import InvalidInputError
from .boundaries import loop_area, named_boundaries, open_strings
from .crs import is_geographic
from .mesh_formats import format_rows, write_text
from .registry import writer

__all__ = ["WALL", "INFLOW", "OUTFLOW", "boundary_conditions", "write_selafin"]

#: (LIHBOR, LIUBOR, LIVBOR, LITBOR) of a solid wall, of a prescribed discharge and of a prescribed depth.
WALL, INFLOW, OUTFLOW = (2, 2, 2, 2), (4, 5, 5, 5), (5, 4, 4, 4)
#: Node-string name prefixes (any case) and their codes; the rest of the border is WALL.
PREFIXES = (("inflow", INFLOW), ("outflow", OUTFLOW), ("open", OUTFLOW))


def boundary_conditions(mesh: TerrainMesh) -> tuple[np.ndarray, np.ndarray]:
    """(boundary nodes in TELEMAC's order as 0-based vertex ids, their (NPTFR, 4) codes): see the module.

    Raises
    ------
    InvalidInputError
        An open node string off the border of the mesh, or a vertex on two
        border loops.
    """
    loops = named_boundaries(mesh)["outline"]  # closed, the domain on the left, the largest first
    v = mesh.vertices
    outer = [lp[:-1] for lp in loops if loop_area(v, lp) >= 0]
    holes = [lp[:-1] for lp in loops if loop_area(v, lp) < 0]
    ordered = []
    for ring in outer:
        start = np.lexsort((v[ring, 1], v[ring, 0]))[0]  # south-west: smallest x, then smallest y
        ordered.append(np.roll(ring, -start))
    nodes = np.concatenate(ordered + holes) if loops else np.empty(0, np.int64)
    counts = np.bincount(nodes, minlength=mesh.n_vertices)
    if (counts > 1).any():
        raise InvalidInputError(
            f"vertex {int(np.argmax(counts > 1))} is on two border loops (the mesh pinches there): "
            "TELEMAC numbers each boundary node once"
        )
    rank = np.full(mesh.n_vertices, -1, np.int64)
    rank[nodes] = np.arange(len(nodes))
    codes = np.tile(np.array(WALL, np.int64), (len(nodes), 1))
    claimed = np.zeros(len(nodes), bool)
    for name, ids in open_strings(mesh, loops).items():  # each edge along the border
        kind = next(c for prefix, c in PREFIXES if name.lower().startswith(prefix))
        if (rank[ids] < 0).any():  # a string of one vertex, off the border
            raise InvalidInputError(f"node string {name!r} is an open boundary but its vertex "
                                    f"{int(ids[rank[ids] < 0][0])} is not on the border of the mesh")
        mine = rank[ids][~claimed[rank[ids]]]
        codes[mine] = kind
        claimed[mine] = True
    return nodes, codes


def _record(fh, *payload: bytes) -> None:
    """One Fortran unformatted sequential record: the byte count, the payload, the byte count."""
    size = np.array([sum(len(p) for p in payload)], ">i4").tobytes()
    fh.write(size)
    for p in payload:
        fh.write(p)
    fh.write(size)


def _tolerance(mesh: TerrainMesh) -> float:
    """Largest coordinate error a single-precision file may make: 1 mm, or 1e-8 degree in a geographic CRS."""
    return 1e-8 if (mesh.crs and is_geographic(mesh.crs)) else 1e-3


@writer([".slf", ".srf", ".selafin"], description="TELEMAC geometry file (SELAFIN: BOTTOM = z, coordinates from "
                                                  "an origin) and its boundary-conditions file .cli (walls; "
                                                  "inflow/outflow/open node strings as liquid boundaries)",
        solver=True, sidecars=(".cli",))
def write_selafin(mesh: TerrainMesh, path, *, grid=None, sidecars) -> None:
    """Write ``mesh`` as a TELEMAC geometry file at ``path`` and its boundary conditions at ``sidecars[0]``."""
    nodes, codes = boundary_conditions(mesh)
    v = mesh.vertices
    origin = np.floor(v[:, :2].min(axis=0))
    if (np.abs(origin) >= 2**31).any():
        raise InvalidInputError(f"the mesh's origin {origin.tolist()} does not fit SELAFIN's 32-bit integers")
    xyz = np.column_stack([v[:, :2] - origin, v[:, 2]])
    single = bool(np.all(np.abs(xyz.astype(np.float32).astype(np.float64) - xyz) <= _tolerance(mesh)))
    real, tag = (">f4", "SERAFIN ") if single else (">f8", "SERAFIND")
    name = " ".join(str(mesh.info.get("name") or "tin").split())
    title = f"{name} (tinsmith {__version__})"[:72].ljust(72) + tag
    ipobo = np.zeros(mesh.n_vertices, np.int64)
    ipobo[nodes] = np.arange(1, len(nodes) + 1)
    iparam = [1, 0, int(origin[0]), int(origin[1]), 0, 0, 0, 0, 0, 0]
    with open(path, "wb") as fh:
        _record(fh, title.encode("ascii", "replace"))
        _record(fh, np.array([1, 0], ">i4").tobytes())
        _record(fh, b"BOTTOM          M               ")
        _record(fh, np.array(iparam, ">i4").tobytes())
        _record(fh, np.array([mesh.n_triangles, mesh.n_vertices, 3, 1], ">i4").tobytes())
        _record(fh, np.ascontiguousarray(mesh.triangles + 1, ">i4").tobytes())
        _record(fh, ipobo.astype(">i4").tobytes())
        _record(fh, xyz[:, 0].astype(real).tobytes())
        _record(fh, xyz[:, 1].astype(real).tobytes())
        _record(fh, np.array([0.0], real).tobytes())
        _record(fh, xyz[:, 2].astype(real).tobytes())
    write_text(sidecars[0], format_rows("%d %d %d 0.000 0.000 0.000 0.000 %d 0.000 0.000 0.000 %d %d\n",
                                        codes, nodes + 1, np.arange(1, len(nodes) + 1)))
