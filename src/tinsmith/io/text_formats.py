"""Text TIN formats of hydraulic and civil-engineering software: SMS 2DM and LandXML.

Both are written here with vectorised formatting (:func:`format_rows`);
coordinates use 17 significant digits, so float64 values read back exactly.
"""

from __future__ import annotations

import datetime as _dt
import os
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np

from .._version import __version__
from ..core import TerrainMesh
from ..errors import FormatError
from .boundaries import named_boundaries, triangle_regions
from .crs import linear_unit, to_epsg, to_wkt
from .mesh_formats import FLOAT, format_rows, indices_from_ids, mesh_from_arrays, sidecar_crs, split_quads, write_text
from .registry import reader, writer

__all__ = ["read_2dm", "read_landxml", "write_2dm", "write_landxml"]

LANDXML_NS = "http://www.landxml.org/schema/LandXML-1.2"


def quoteattr(value: str) -> str:
    """``xml.sax.saxutils.quoteattr``, imported when a LandXML file is written (it imports urllib: slow to start)."""
    from xml.sax.saxutils import quoteattr as quote

    return quote(value)


def _mesh_name(mesh: TerrainMesh) -> str:
    """Name written into the file: ``info["name"]``, else "tin" (writers only see a temporary path)."""
    return str(mesh.info.get("name") or "tin")


# -- SMS 2DM ----------------------------------------------------------------------------------


@writer([".2dm"], description="SMS 2DM mesh (TUFLOW, BASEMENT, HEC-RAS import; E3T elements with a material per "
                               "region, named node strings: outline loops, breaklines, the mesh's own)", solver=True)
def write_2dm(mesh: TerrainMesh, path, *, grid=None) -> None:
    """Write ``MESH2D``, the header cards, ``E3T``, ``ND`` and ``NS`` lines.

    Ids are 1-based; elements are counter-clockwise seen from above, as 2DM
    expects.  The material of an element is 1 outside every region and
    ``k + 1`` in region ``k`` (:func:`.boundaries.triangle_regions`).  Node
    strings (``NS``, ten ids a line, the last id negative and followed by the
    string's name, as BASEMENT and Py2DM read it): ``outline_1``, ...  for the
    loops of the border (the outer one first, closed: the first node
    repeated) and ``breakline_1``, ... for the breaklines
    (:func:`.boundaries.named_boundaries`), then the mesh's own
    ``node_strings`` under their names (one of the same name as a loop or a
    breakline replaces it): the boundary segments of
    :func:`.boundaries.segment_outline`.  The CRS goes to a ``.prj``
    sidecar (written by the dispatcher).
    """
    name = _mesh_name(mesh).replace('"', "'")
    m, n = mesh.n_triangles, mesh.n_vertices
    region, _ = triangle_regions(mesh)
    lines = named_boundaries(mesh)
    strings = [(f"outline_{k + 1}", s) for k, s in enumerate(lines["outline"])]
    strings += [(f"breakline_{k + 1}", s) for k, s in enumerate(lines["breaklines"])]
    own = {label: ids for label, ids in mesh.node_strings.items() if len(ids) >= 2}
    strings = [(label, s) for label, s in strings if label not in own] + list(own.items())
    write_text(
        path,
        [
            f'MESH2D\nMESHNAME "{name}"\nNUM_MATERIALS_PER_ELEM 1\n',
            *format_rows("E3T %d %d %d %d %d\n", np.arange(1, m + 1), mesh.triangles + 1, region + 1),
            *format_rows(f"ND %d {FLOAT} {FLOAT} {FLOAT}\n", np.arange(1, n + 1), mesh.vertices),
            *(_node_string(label, ids + 1) for label, ids in strings),
        ],
    )


def _node_string(label: str, ids: np.ndarray) -> str:
    """``NS`` lines of ten ids at most, the last id negative and followed by the name."""
    ids = ids.astype(np.int64).copy()
    ids[-1] = -ids[-1]
    rows = [" ".join(map(str, ids[k:k + 10].tolist())) for k in range(0, len(ids), 10)]
    return "".join(f"NS {row}" + (f" {label}\n" if k == len(rows) - 1 else "\n") for k, row in enumerate(rows))


#: 2DM element cards read, with the columns (after the card) of their corner nodes.
_2DM_ELEMENTS = {
    "E3T": (1, 2, 3),
    "E6T": (1, 3, 5),  # quadratic triangle: corners are nodes 1, 3, 5
    "E4Q": (1, 2, 3, 4),
    "E8Q": (1, 3, 5, 7),  # quadratic quadrilaterals: corners are nodes 1, 3, 5, 7
    "E9Q": (1, 3, 5, 7),
}


def _table(lines: list[str], columns, dtype) -> np.ndarray:
    if not lines:
        return np.empty((0, len(columns)), dtype=dtype)
    return np.loadtxt(lines, usecols=columns, dtype=dtype, ndmin=2, comments=None)


@reader([".2dm"], kind="mesh", description="SMS 2DM mesh (E3T/E6T triangles, E4Q/E8Q/E9Q quads split in two)")
def read_2dm(path) -> TerrainMesh:
    """Read the nodes and the triangle and quadrilateral elements of a 2DM file.

    Quadratic elements keep their corner nodes; quadrilaterals become two
    triangles; node strings (``NS``) go to ``mesh.node_strings`` (name:
    0-based node indices; unnamed strings are called ``nodestring_K``);
    materials, when every element has one and they are not all 1, go to
    ``triangle_attributes["region"]`` as material - 1 (the inverse of
    :func:`write_2dm`); other cards (boundary conditions, ...) are ignored.
    Node ids need not be contiguous.  CRS from a ``.prj`` sidecar.
    """
    path = Path(path)
    cards: dict[str, list[str]] = {"MESHNAME": [], "ND": [], "NS": [], **{k: [] for k in _2DM_ELEMENTS}}
    first = None
    with open(path, encoding="utf-8", errors="replace") as fh:
        for line in fh:
            parts = line.split(None, 1)
            if not parts:
                continue
            if first is None:
                first = parts[0]
            rows = cards.get(parts[0])
            if rows is not None:
                rows.append(parts[1] if len(parts) > 1 else "")
    if first != "MESH2D":
        raise FormatError(f"{str(path)!r} is not a 2DM mesh: it does not start with MESH2D")
    nodes = _table(cards["ND"], (0, 1, 2, 3), np.float64)
    node_ids = nodes[:, 0].astype(np.int64)
    blocks, materials = [], []
    for card, corners in _2DM_ELEMENTS.items():
        refs, material = _elements(cards[card], corners, _2DM_MATERIAL_COLUMN[card])
        if len(refs):
            idx = indices_from_ids(node_ids, refs, path, "node")
            blocks.append(idx if len(corners) == 3 else split_quads(idx))
            materials.append(material if material is None or len(corners) == 3 else np.concatenate([material] * 2))
    name = cards["MESHNAME"][0].strip().strip('"') if cards["MESHNAME"] else None
    strings = {}
    for label, ids in _node_strings(cards["NS"], path):
        key, k = label, 1
        while key in strings:  # the same name twice: the later one numbered
            k += 1
            key = f"{label}_{k}"
        strings[key] = indices_from_ids(node_ids, ids, path, "node")
    attributes = {}
    if materials and all(m is not None for m in materials):
        material = np.concatenate(materials)
        if (material >= 1).all() and (material > 1).any():
            attributes["region"] = material - 1
    return mesh_from_arrays(path, nodes[:, 1:], blocks, crs=sidecar_crs(path), info={"name": name or None},
                            node_strings=strings, triangle_attributes=attributes)


#: The column (after the card) of an element's material: after its id and nodes.
_2DM_MATERIAL_COLUMN = {"E3T": 4, "E6T": 7, "E4Q": 5, "E8Q": 9, "E9Q": 10}


def _elements(lines: list[str], corners, column: int) -> tuple[np.ndarray, np.ndarray | None]:
    """The corner node ids of every element of one card, and their materials (None when some element has none)."""
    try:
        table = _table(lines, (*corners, column), np.int64)
    except (ValueError, IndexError):
        return _table(lines, corners, np.int64), None
    return table[:, :-1], table[:, -1]


def _node_strings(rows: list[str], path) -> list[tuple[str, np.ndarray]]:
    """(name, node ids) of the ``NS`` cards: ids run on over lines until a negative one, which a name may follow."""
    out, ids = [], []
    for row in rows:
        tokens = row.split()
        for k, token in enumerate(tokens):
            try:
                v = int(token)
            except ValueError:
                raise FormatError(f"{str(path)!r}: a node string holds {token!r} where a node id belongs") from None
            ids.append(abs(v))
            if v < 0:
                label = tokens[k + 1] if k + 1 < len(tokens) else f"nodestring_{len(out) + 1}"
                out.append((label, np.asarray(ids, np.int64)))
                ids = []
                break
    return out


# -- LandXML ------------------------------------------------------------------------------------


def _units_element(wkt: str | None) -> str:
    """``<Units>`` for the CRS's horizontal unit: Imperial for feet, Metric otherwise."""
    unit = linear_unit(wkt).lower().replace("_", " ")
    if "foot" in unit or "feet" in unit:
        linear = "USSurveyFoot" if ("us" in unit.split() or "survey" in unit) else "foot"
        return (
            f'<Imperial linearUnit="{linear}" areaUnit="squareFoot" volumeUnit="cubicFeet" '
            'temperatureUnit="fahrenheit" pressureUnit="inchHG" '
            'angularUnit="decimal degrees" directionUnit="decimal degrees"/>'
        )
    return (
        '<Metric linearUnit="meter" areaUnit="squareMeter" volumeUnit="cubicMeter" '
        'temperatureUnit="celsius" pressureUnit="milliBars" '
        'angularUnit="decimal degrees" directionUnit="decimal degrees"/>'
    )


def _timestamp() -> _dt.datetime:
    """``SOURCE_DATE_EPOCH`` (reproducible builds) when set, else now; UTC."""
    epoch = os.environ.get("SOURCE_DATE_EPOCH")
    if epoch:
        try:
            return _dt.datetime.fromtimestamp(int(epoch), _dt.UTC)
        except (ValueError, OverflowError, OSError):
            pass
    return _dt.datetime.now(_dt.UTC)


@writer(
    [".landxml", ".xml"],
    description="LandXML 1.2 TIN surface (Civil 3D, OpenRoads, 12d, Trimble; points are northing easting elevation)",
    carries_crs=True,
)
def write_landxml(mesh: TerrainMesh, path, *, grid=None) -> None:
    """Write a LandXML 1.2 document with one TIN surface.

    ``<P id="i">northing easting elevation</P>`` (1-based ids, i.e. ``y x z``)
    and ``<F>i j k</F>`` (counter-clockwise seen from above).  Units follow
    the CRS's horizontal unit; the CRS itself goes into
    ``<CoordinateSystem ogcWktCode=... epsgCode=...>``.
    """
    when = _timestamp()
    crs = to_wkt(mesh.crs) if mesh.crs else None
    head = [
        '<?xml version="1.0" encoding="UTF-8"?>\n',
        f'<LandXML xmlns="{LANDXML_NS}" version="1.2" '
        f'date="{when:%Y-%m-%d}" time="{when:%H:%M:%S}">\n',
        f"  <Units>\n    {_units_element(crs)}\n  </Units>\n",
    ]
    if crs:
        epsg = to_epsg(crs)
        code = f' epsgCode="{epsg}"' if epsg else ""
        head.append(f"  <CoordinateSystem{code} ogcWktCode={quoteattr(crs)}/>\n")
    head.append(f'  <Application name="tinsmith" manufacturer="tinsmith developers" version="{__version__}"/>\n')
    z = mesh.vertices[:, 2]
    elev = f' elevMin="{FLOAT % z.min()}" elevMax="{FLOAT % z.max()}"' if len(z) else ""
    head.append(
        f"  <Surfaces>\n    <Surface name={quoteattr(_mesh_name(mesh))}>\n"
        f'      <Definition surfType="TIN"{elev}>\n        <Pnts>\n'
    )
    v = mesh.vertices
    write_text(
        path,
        [
            *head,
            *format_rows(
                f'          <P id="%d">{FLOAT} {FLOAT} {FLOAT}</P>\n',
                np.arange(1, mesh.n_vertices + 1),
                v[:, [1, 0, 2]],
            ),
            "        </Pnts>\n        <Faces>\n",
            *format_rows("          <F>%d %d %d</F>\n", mesh.triangles + 1),
            "        </Faces>\n      </Definition>\n    </Surface>\n  </Surfaces>\n</LandXML>\n",
        ],
    )


def _local(tag: str) -> str:
    return tag.rsplit("}", 1)[-1]


def _landxml_crs(elem) -> str | None:
    for value in (elem.get("ogcWktCode"), elem.get("epsgCode") and f"EPSG:{elem.get('epsgCode')}"):
        if value:
            try:
                return to_wkt(value)
            except Exception:
                continue
    return None


@reader([".landxml", ".xml"], kind="mesh", description="LandXML TIN surface (the first surface of the file)")
def read_landxml(path) -> TerrainMesh:
    """Read the first ``<Surface>`` of a LandXML file (any LandXML version).

    Point ids are mapped to indices (they need not be contiguous); faces
    marked invisible (``i="1"``) are left out; 4-point faces (grid surfaces)
    become two triangles.  The CRS comes from ``<CoordinateSystem>``
    (``ogcWktCode``, else ``epsgCode``), else from a ``.prj`` sidecar.
    """
    path = Path(path)
    surfaces, name, ids, points, faces, crs = _landxml_first_surface(path)
    if surfaces == 0:
        raise FormatError(f"{str(path)!r} holds no <Surface>")
    if not points:
        raise FormatError(f"{str(path)!r}: the surface {name!r} has no points")
    if any(i is None for i in ids):
        raise FormatError(f"{str(path)!r}: a <P> element has no id")
    northing_easting_z = np.loadtxt(points, dtype=np.float64, ndmin=2, comments=None)
    if northing_easting_z.shape[1] != 3:
        raise FormatError(f"{str(path)!r}: points must hold 'northing easting elevation'")
    vertices = northing_easting_z[:, [1, 0, 2]]
    blocks = _landxml_faces(path, ids, faces) if faces else []
    return mesh_from_arrays(path, vertices, blocks, crs=crs or sidecar_crs(path), info={"name": name})


def _landxml_first_surface(path: Path) -> tuple:
    """(surfaces in the file, and of the first one: its name, point ids, point texts, visible face texts; the CRS).

    One streaming pass: elements are cleared as they are read.
    """
    ids: list[str] = []
    points: list[str] = []
    faces: list[str] = []
    crs = None
    name = None
    surfaces = 0  # surfaces opened so far; only the first one is read
    in_first = False
    root_tag = None
    for event, elem in ET.iterparse(path, events=("start", "end")):
        tag = _local(elem.tag)
        if event == "start":
            if root_tag is None:
                root_tag = tag
                if tag != "LandXML":
                    raise FormatError(f"{str(path)!r} is not LandXML: its root element is <{tag}>")
            if tag == "Surface":
                surfaces += 1
                in_first = surfaces == 1
                if in_first:
                    name = elem.get("name")
            continue
        if tag == "P":
            if in_first:
                ids.append(elem.get("id"))
                points.append(elem.text or "")
            elem.clear()
        elif tag == "F":
            if in_first and elem.get("i", "0").strip() not in ("1", "true"):
                faces.append(elem.text or "")
            elem.clear()
        elif tag == "Surface":
            in_first = False
            elem.clear()
        elif tag == "CoordinateSystem" and crs is None:
            crs = _landxml_crs(elem)
    return surfaces, name, ids, points, faces, crs


def _landxml_faces(path: Path, ids: list[str], faces: list[str]) -> list[np.ndarray]:
    """The faces as one block of (T, 3) vertex indices: triangles as they are, 4-point faces split in two."""
    refs = np.loadtxt(faces, dtype=np.int64, ndmin=2, comments=None)
    idx = indices_from_ids(np.asarray(ids, dtype=np.int64), refs, path, "point")
    if refs.shape[1] == 3:
        return [idx]
    if refs.shape[1] == 4:
        return [split_quads(idx)]
    raise FormatError(f"{str(path)!r}: faces must list 3 (TIN) or 4 (grid) point ids")
