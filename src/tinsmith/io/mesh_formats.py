"""Triangle-mesh formats: PLY, OBJ, STL, OFF, VTK, VTU, Gmsh and glTF.

Writers go through meshio (PLY, STL, VTK, VTU, Gmsh) and trimesh (glTF); OBJ
and OFF are written here so that every float64 coordinate round-trips
exactly and large meshes format quickly.  Readers return a
:class:`TerrainMesh` with the CRS of a ``.prj`` sidecar beside the file, if
there is one (glTF: from the scene extras a tinsmith writer leaves).

A mesh's numeric one-column attributes go to the formats that hold data
arrays and come back from them: VTK and VTU (cell data per triangle, point
data per vertex) and PLY (vertex properties; PLY face properties are not
written, since meshio's PLY writer has none and its binary reader fails on
them).  Named patches (a city model) become OBJ groups and STL solids.

The module also holds the helpers the other text and mesh formats share:
:func:`format_rows` (fast exact number formatting), :func:`sidecar_crs`,
:func:`indices_from_ids`, :func:`split_quads` and :func:`mesh_from_arrays`.
"""

from __future__ import annotations

import contextlib
import io
import warnings
from collections.abc import Iterable, Iterator
from pathlib import Path

import numpy as np

from ..core import TerrainMesh
from ..errors import FormatError, InvalidInputError
from .boundaries import named_boundaries, triangle_regions
from .crs import to_epsg, to_wkt
from .registry import reader, writer

__all__ = [
    "FLOAT",
    "format_rows",
    "indices_from_ids",
    "mesh_from_arrays",
    "quiet",
    "sidecar_crs",
    "split_quads",
    "write_text",
]

#: printf format of a float64 that reads back bit for bit (17 significant digits,
#: trailing zeros dropped: 500001.0 -> "500001", 0.1 -> "0.10000000000000001").
FLOAT = "%.17g"

#: Rows formatted per string by :func:`format_rows` (bounds the memory of a chunk).
_CHUNK = 1 << 16


# -- helpers shared by the format modules ----------------------------------------------


def format_rows(row_format: str, *columns, chunk: int = _CHUNK) -> Iterator[str]:
    """Format the rows of ``columns`` with one printf template, a chunk at a time.

    The template is applied to a whole chunk in one ``%`` operation, which is
    several times faster than formatting row by row.

    Parameters
    ----------
    row_format : str
        printf template of one row, including its line end, e.g.
        ``"v %.17g %.17g %.17g\\n"``; it must take as many values as the
        columns hold together.
    *columns : (N,) or (N, k) array_like
        Side-by-side column blocks with the same number of rows.  Integer
        columns stay integers (format them with ``%d``).
    chunk : int
        Rows per yielded string.

    Yields
    ------
    str
        The formatted rows, ``chunk`` at a time.
    """
    blocks = [np.asarray(c) for c in columns]
    blocks = [b.reshape(len(b), -1) for b in blocks]
    n = len(blocks[0])
    if any(len(b) != n for b in blocks):
        raise ValueError("format_rows needs columns with the same number of rows")
    width = sum(b.shape[1] for b in blocks)
    for start in range(0, n, chunk):
        stop = min(n, start + chunk)
        if len(blocks) == 1:
            values = blocks[0][start:stop].ravel().tolist()
        else:  # mixed ints and floats: an object block keeps each column's type
            block = np.empty((stop - start, width), dtype=object)
            j = 0
            for b in blocks:
                block[:, j : j + b.shape[1]] = b[start:stop]
                j += b.shape[1]
            values = block.ravel().tolist()
        yield (row_format * (stop - start)) % tuple(values)


def write_text(path, parts: Iterable[str]) -> None:
    """Write strings to ``path`` as UTF-8 with ``\\n`` line ends."""
    with open(path, "w", encoding="utf-8", newline="\n") as fh:
        fh.writelines(parts)


def sidecar_crs(path) -> str | None:
    """WKT of the ``.prj`` file beside ``path`` (same name, suffix ``.prj``), or None.

    Raises
    ------
    FormatError
        When the ``.prj`` file exists but holds no CRS rasterio understands.
    """
    prj = Path(path).with_suffix(".prj")
    if not prj.is_file():
        return None
    text = prj.read_text(encoding="utf-8", errors="replace").strip()
    if not text:
        return None
    try:
        return to_wkt(text)
    except Exception as exc:
        raise FormatError(f"cannot read the CRS in {str(prj)!r}: {exc}") from exc


def indices_from_ids(ids, refs, path, what: str = "node") -> np.ndarray:
    """Map the ids a file uses to 0-based positions.

    Parameters
    ----------
    ids : (N,) array_like of int
        The id of each vertex, in file order (need not be contiguous or sorted).
    refs : array_like of int
        Ids referenced by the elements, any shape.
    path : str or Path
        The file, for error messages.
    what : str
        What the ids number ("node", "point"), for error messages.

    Returns
    -------
    ndarray of int64
        Positions in ``ids``, with the shape of ``refs``.

    Raises
    ------
    FormatError
        For duplicate ids, or references to ids that do not exist.
    """
    ids = np.asarray(ids, dtype=np.int64)
    refs = np.asarray(refs, dtype=np.int64)
    order = np.argsort(ids, kind="stable")
    sorted_ids = ids[order]
    if len(sorted_ids) > 1 and (np.diff(sorted_ids) == 0).any():
        dup = sorted_ids[1:][np.diff(sorted_ids) == 0][0]
        raise FormatError(f"{str(path)!r} defines {what} id {dup} more than once")
    pos = np.searchsorted(sorted_ids, refs)
    pos = np.minimum(pos, max(len(sorted_ids) - 1, 0))
    found = sorted_ids[pos] == refs if len(sorted_ids) else np.zeros(refs.shape, dtype=bool)
    if not found.all():
        missing = refs[~found].ravel()[0]
        raise FormatError(f"{str(path)!r} refers to {what} id {missing}, which it does not define")
    return order[pos]


def split_quads(quads) -> np.ndarray:
    """(Q, 4) quadrilaterals -> (2Q, 3) triangles, cut along the diagonal 0-2 (orientation kept)."""
    q = np.asarray(quads, dtype=np.int64).reshape(-1, 4)
    return np.concatenate([q[:, [0, 1, 2]], q[:, [0, 2, 3]]])


def mesh_from_arrays(path, vertices, triangles, *, crs: str | None = None, info: dict | None = None,
                     **fields) -> TerrainMesh:
    """A :class:`TerrainMesh` from the arrays a reader found in ``path``.

    Parameters
    ----------
    path : str or Path
        The file read (goes to ``info["source"]`` and into error messages).
    vertices : (N, 2) or (N, 3) array_like of float
        2-D vertices get z = 0.
    triangles : (M, 3) array_like of int, or a list of such blocks
        0-based vertex indices.
    crs : str, optional
        WKT.
    info : dict, optional
        Extra entries for ``info``.
    **fields
        The mesh's typed data the file held (``triangle_attributes``,
        ``node_strings``, ...: see :class:`TerrainMesh`).

    Raises
    ------
    InvalidInputError
        When the file holds no triangles.
    FormatError
        When indices or coordinates are out of order (damaged file).
    """
    v = np.asarray(vertices, dtype=np.float64)
    if v.ndim == 2 and v.shape[1] == 2:
        v = np.column_stack([v, np.zeros(len(v))])
    if isinstance(triangles, (list, tuple)):
        blocks = [np.asarray(t, dtype=np.int64).reshape(-1, 3) for t in triangles]
        t = np.concatenate(blocks) if blocks else np.empty((0, 3), dtype=np.int64)
    else:
        t = np.asarray(triangles, dtype=np.int64).reshape(-1, 3)
    if len(t) == 0:
        raise InvalidInputError(f"{str(path)!r} holds no triangles")
    try:
        return TerrainMesh(v, t, crs=crs, info={"source": str(path), **(info or {})}, **fields)
    except InvalidInputError as exc:
        raise FormatError(f"{str(path)!r} is damaged: {exc}") from exc


@contextlib.contextmanager
def quiet():
    """Silence the warnings and console messages libraries print (meshio uses rich on stderr)."""
    sink = io.StringIO()
    with warnings.catch_warnings(), contextlib.redirect_stderr(sink), contextlib.redirect_stdout(sink):
        warnings.simplefilter("ignore")
        yield


# -- meshio formats -------------------------------------------------------------------------


def _meshio_write(mesh: TerrainMesh, path, file_format: str, *, cell_data=None, point_data=None, **options) -> None:
    import meshio

    # int32 indices: PLY has no 64-bit integers and the other formats do not need them
    cells = [("triangle", mesh.triangles.astype(np.int32))]
    data = meshio.Mesh(mesh.vertices, cells, cell_data=cell_data or {}, point_data=point_data or {})
    with quiet():
        meshio.write(path, data, file_format=file_format, **options)


def data_arrays(attributes, *, int64: bool = True) -> dict[str, np.ndarray]:
    """The attributes a format's data arrays hold: one column of numbers (booleans as uint8).

    Without ``int64`` (PLY), 64-bit integers are written as int32 when every
    value fits, and left out otherwise.
    """
    out = {}
    for name, a in attributes.items():
        if a.ndim != 1 or a.dtype.kind not in "biuf":
            continue
        if a.dtype.kind == "b":
            a = a.astype(np.uint8)
        elif not int64 and a.dtype.kind in "iu" and a.dtype.itemsize == 8:
            info = np.iinfo(np.int32)
            if a.size and (a.min() < info.min or a.max() > info.max):
                continue
            a = a.astype(np.int32)
        out[name] = a
    return out


@writer([".ply"], description="PLY mesh (binary little-endian, float64 vertices; numeric vertex attributes)")
def write_ply(mesh: TerrainMesh, path, *, grid=None) -> None:
    """PLY through meshio, binary in the machine's byte order (little-endian on x86/ARM); the vertex
    attributes that are one column of numbers as vertex properties."""
    _meshio_write(mesh, path, "ply", binary=True, point_data=data_arrays(mesh.vertex_attributes, int64=False))


@writer([".stl"], description="STL mesh (binary; a city model: ASCII, one named solid per patch)")
def write_stl(mesh: TerrainMesh, path, *, grid=None) -> None:
    """Binary STL through meshio.  STL stores float32: about 0.5 m steps at UTM northings.

    A mesh with patches (a city model, :func:`tinsmith.city`) is written as
    ASCII STL with one ``solid NAME`` per patch (ground, buildings, walls,
    sides, bottom), as OpenFOAM's snappyHexMesh and surfaceFeatureExtract
    read them; coordinates in full precision.
    """
    patches = _patches(mesh)
    if patches is None:
        _meshio_write(mesh, path, "stl", binary=True)
        return
    v = mesh.vertices
    parts = []
    for name, sel in patches:
        tri = mesh.triangles[sel]
        a, b, c = v[tri[:, 0]], v[tri[:, 1]], v[tri[:, 2]]
        normal = np.cross(b - a, c - a)
        length = np.linalg.norm(normal, axis=1, keepdims=True)
        normal = normal / np.where(length > 0, length, 1.0)
        rows = np.column_stack([normal, a, b, c])
        parts += [f"solid {name}\n",
                  *format_rows("facet normal %.9g %.9g %.9g\n outer loop\n"
                               f"  vertex {FLOAT} {FLOAT} {FLOAT}\n  vertex {FLOAT} {FLOAT} {FLOAT}\n"
                               f"  vertex {FLOAT} {FLOAT} {FLOAT}\n endloop\nendfacet\n", rows),
                  f"endsolid {name}\n"]
    write_text(path, parts)


def _patches(mesh: TerrainMesh):
    """[(name, triangle mask)] of the named patches a mesh records (``triangle_attributes["patch"]``, named in
    ``labels["patch"]``), or None."""
    patch = mesh.triangle_attributes.get("patch")
    names = mesh.labels.get("patch")
    if patch is None or names is None:
        return None
    patch = np.asarray(patch)
    return [(name, patch == k) for k, name in sorted(names.items()) if np.any(patch == k)]


def _vtk_data(mesh: TerrainMesh) -> dict:
    """The attributes as VTK cell data (per triangle) and point data (per vertex)."""
    return {"cell_data": {k: [v] for k, v in data_arrays(mesh.triangle_attributes).items()},
            "point_data": data_arrays(mesh.vertex_attributes)}


@writer([".vtk"], description="legacy VTK unstructured grid (version 4.2, binary, float64 vertices, attributes as "
                               "cell and point data)")
def write_vtk(mesh: TerrainMesh, path, *, grid=None) -> None:
    """Legacy VTK 4.2 (readable by every VTK/ParaView version; 5.1 needs VTK >= 9)."""
    _meshio_write(mesh, path, "vtk42", binary=True, **_vtk_data(mesh))


@writer([".vtu"], description="VTK XML unstructured grid (zlib-compressed, float64 vertices, attributes as cell "
                               "and point data)")
def write_vtu(mesh: TerrainMesh, path, *, grid=None) -> None:
    """VTU through meshio."""
    _meshio_write(mesh, path, "vtu", binary=True, compression="zlib", **_vtk_data(mesh))


@writer([".msh"], description="Gmsh MSH 2.2 ASCII (physical groups: the terrain and its regions, the outline, "
                               "the breaklines, the mesh's node strings)", solver=True)
def write_msh(mesh: TerrainMesh, path, *, grid=None) -> None:
    """Gmsh 2.2 ASCII, the version CFD and coastal tools (OpenFOAM's gmshToFoam, TELEMAC, ANUGA) read.

    Physical groups, named in ``$PhysicalNames``: surface 1 ``terrain`` and
    surface ``k + 1`` for region ``k`` (:func:`.boundaries.triangle_regions`);
    line 1 ``outline`` (every border edge; its elementary tag numbers the loop,
    the outer one 1) and line 2 ``breaklines`` (elementary tags go on
    numbering them), from :func:`.boundaries.named_boundaries`; then line
    ``3``, ``4``, ... for each of the mesh's ``node_strings``, under its name
    (the boundary segments of :func:`.boundaries.segment_outline`).  Nodes are
    written with 17 significant digits (exact float64).
    """
    import meshio

    region, names = triangle_regions(mesh)
    lines = named_boundaries(mesh)
    cells, physical, elementary = [], [], []
    field_data = {}
    entity = 0
    groups = [(1, "outline", lines["outline"]), (2, "breaklines", lines["breaklines"])]
    own = [(name, ids) for name, ids in mesh.node_strings.items() if len(ids) >= 2 and name not in ("outline", "breaklines")]
    groups += [(3 + k, name, [ids]) for k, (name, ids) in enumerate(own)]
    for tag, group, polylines in groups:
        if not polylines:
            continue
        field_data[group] = np.array([tag, 1])
        for line in polylines:
            entity += 1
            cells.append(("line", np.column_stack([line[:-1], line[1:]]).astype(np.int32)))
            physical.append(np.full(len(line) - 1, tag, np.int32))
            elementary.append(np.full(len(line) - 1, entity, np.int32))
    for k, name in enumerate(names):
        label = name if name not in field_data else f"{name}_surface"
        field_data[label] = np.array([k + 1, 2])
    cells.append(("triangle", mesh.triangles.astype(np.int32)))
    physical.append((region + 1).astype(np.int32))
    elementary.append((region + 1).astype(np.int32))
    data = meshio.Mesh(mesh.vertices, cells, cell_data={"gmsh:physical": physical, "gmsh:geometrical": elementary},
                       field_data=field_data)
    with quiet():
        meshio.write(path, data, file_format="gmsh22", binary=False, float_fmt=".16e")


# -- OBJ and OFF, written here --------------------------------------------------------------


@writer([".obj"], description="Wavefront OBJ (text, exact float64 vertices)")
def write_obj(mesh: TerrainMesh, path, *, grid=None) -> None:
    """``v x y z`` lines then ``f i j k`` lines (1-based), counter-clockwise seen from +z.

    A city model gets one ``g`` group per patch.
    """
    header = f"# tinsmith TIN: {mesh.n_vertices} vertices, {mesh.n_triangles} triangles\n"
    patches = _patches(mesh)  # a city model: one group per patch
    faces = (
        [part for name, sel in patches for part in (f"g {name}\n", *format_rows("f %d %d %d\n", mesh.triangles[sel] + 1))]
        if patches is not None else list(format_rows("f %d %d %d\n", mesh.triangles + 1))
    )
    write_text(path, [header, *format_rows(f"v {FLOAT} {FLOAT} {FLOAT}\n", mesh.vertices), *faces])


@writer([".off"], description="OFF mesh (text, exact float64 vertices)")
def write_off(mesh: TerrainMesh, path, *, grid=None) -> None:
    """``OFF``, the counts, vertex lines, then ``3 i j k`` lines (0-based)."""
    write_text(
        path,
        [
            f"OFF\n{mesh.n_vertices} {mesh.n_triangles} 0\n",
            *format_rows(f"{FLOAT} {FLOAT} {FLOAT}\n", mesh.vertices),
            *format_rows("3 %d %d %d\n", mesh.triangles),
        ],
    )


# -- glTF --------------------------------------------------------------------------------------

#: glTF is +Y up: (x, y, z) in the CRS -> (x, z, -y).  A rotation (determinant +1),
#: so counter-clockwise faces seen from +z are counter-clockwise seen from +Y.
_Z_UP_TO_Y_UP = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]])


def _to_y_up(xyz: np.ndarray) -> np.ndarray:
    """(N, 3) CRS coordinates (z up) -> glTF frame (y up)."""
    return np.asarray(xyz, dtype=np.float64) @ _Z_UP_TO_Y_UP.T


def _from_y_up(xyz: np.ndarray) -> np.ndarray:
    """(N, 3) glTF frame (y up) -> CRS coordinates (z up)."""
    return np.asarray(xyz, dtype=np.float64) @ _Z_UP_TO_Y_UP


def _vertex_normals(vertices: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """(N, 3) unit vertex normals: the area-weighted sum of the incident face normals.

    Computed here because trimesh falls back to a slow Python loop without scipy.
    """
    p = vertices[triangles]
    face = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])  # length = twice the area
    normals = np.column_stack(
        [np.bincount(triangles.ravel(), weights=np.repeat(face[:, k], 3), minlength=len(vertices)) for k in range(3)]
    )
    length = np.linalg.norm(normals, axis=1, keepdims=True)
    return np.divide(normals, length, out=np.zeros_like(normals), where=length > 0)


def gltf_origin(mesh: TerrainMesh) -> np.ndarray:
    """(3,) CRS point the glTF positions are relative to: the bounding-box centre, rounded to whole units."""
    v = mesh.vertices
    return np.round((v.min(axis=0) + v.max(axis=0)) / 2.0)


_GLTF = (
    "glTF 2.0 (.gltf: JSON with the buffer embedded; .glb: binary); Y up, float32 positions "
    "relative to an origin in the node translation; CRS WKT in the scene extras"
)


@writer([".gltf"], description=_GLTF, carries_crs=True)
def write_gltf(mesh: TerrainMesh, path, *, grid=None, binary: bool | None = None) -> None:
    """glTF through trimesh: JSON with the buffer embedded, or binary (``binary``; default: a ``.glb`` path).

    Positions are ``(x - ox, z - oz, -(y - oy))`` as float32 with the origin
    ``o`` from :func:`gltf_origin`; the mesh node's ``translation`` is
    ``(ox, oz, -oy)``, so viewers place the terrain at its CRS coordinates
    (in glTF's Y-up frame).  Vertex normals are included for smooth shading.
    The scene's ``extras`` hold ``crs`` (WKT), ``epsg`` and ``origin``
    (``[ox, oy, oz]`` in CRS axes).
    """
    import trimesh

    if mesh.n_triangles == 0:
        raise InvalidInputError("the mesh has no triangles; glTF cannot hold bare vertices")
    origin = gltf_origin(mesh)
    positions = _to_y_up(mesh.vertices - origin)
    tm = trimesh.Trimesh(
        positions, mesh.triangles, vertex_normals=_vertex_normals(positions, mesh.triangles),
        process=False, validate=False,
    )
    scene = trimesh.Scene()
    scene.add_geometry(tm, geom_name="tin", node_name="tin")
    extras = {"origin": origin.tolist(), "up_axis": "Y", "generator": "tinsmith"}
    if mesh.crs:
        extras["crs"] = to_wkt(mesh.crs)
        epsg = to_epsg(mesh.crs)
        if epsg:
            extras["epsg"] = epsg
    scene.metadata.update(extras)
    translation = _to_y_up(origin[None, :])[0].tolist()

    def place(tree: dict) -> None:
        tree["asset"]["generator"] = "tinsmith (trimesh)"
        for node in tree.get("nodes", []):
            if "mesh" in node:
                node.pop("matrix", None)
                node["translation"] = translation

    if binary if binary is not None else Path(path).suffix.lower() == ".glb":
        data = trimesh.exchange.gltf.export_glb(scene, include_normals=True, tree_postprocessor=place)
    else:
        files = trimesh.exchange.gltf.export_gltf(
            scene, include_normals=True, merge_buffers=True, embed_buffers=True, tree_postprocessor=place
        )
        data = files["model.gltf"]
    Path(path).write_bytes(data)


@writer([".glb"], description=_GLTF, carries_crs=True)
def write_glb(mesh: TerrainMesh, path, *, grid=None) -> None:
    """Binary glTF (GLB), whatever ``path`` is called (see :func:`write_gltf`)."""
    write_gltf(mesh, path, grid=grid, binary=True)


# -- readers ---------------------------------------------------------------------------------

_MESHIO_READ_FORMATS = {
    ".ply": "ply",
    ".obj": "obj",
    ".stl": "stl",
    ".off": "off",
    ".vtk": "vtk",
    ".vtu": "vtu",
    ".msh": "gmsh",
}


@reader(
    list(_MESHIO_READ_FORMATS),
    kind="mesh",
    description="triangle mesh (PLY, OBJ, STL, OFF, VTK, VTU, Gmsh) read with meshio",
)
def read_meshio(path) -> TerrainMesh:
    """Read the triangle cells of a mesh file; quads are cut into two triangles, other cells ignored.

    STL's unindexed triangles come back with identical vertices merged (meshio
    does it).  The CRS comes from a ``.prj`` sidecar, if any.
    """
    import meshio

    path = Path(path)
    try:
        with quiet():
            data = meshio.read(path, file_format=_MESHIO_READ_FORMATS[path.suffix.lower()])
    except SystemExit:  # meshio ends the interpreter on some damaged files instead of raising
        raise FormatError(f"cannot read {str(path)!r} as {_MESHIO_READ_FORMATS[path.suffix.lower()]}: "
                          "meshio could not parse it (empty or damaged?)") from None
    blocks = [c.data for c in data.cells if c.type == "triangle"]
    blocks += [split_quads(c.data) for c in data.cells if c.type == "quad"]
    if not blocks:
        found = ", ".join(sorted({c.type for c in data.cells})) or "no cells"
        raise InvalidInputError(f"{str(path)!r} holds no triangles (found: {found})")
    fields = _attributes_read(data) if path.suffix.lower() in _DATA_ARRAY_SUFFIXES else {}
    return mesh_from_arrays(path, data.points, blocks, crs=sidecar_crs(path), **fields)


#: The formats whose data arrays are read back as attributes (those :func:`data_arrays` writes to).
_DATA_ARRAY_SUFFIXES = (".vtk", ".vtu", ".ply")


def _attributes_read(data) -> dict:
    """The one-column point and cell data of a meshio mesh as vertex and triangle attributes (in the order
    :func:`read_meshio` puts the triangles: triangle blocks, then each quad block's two halves)."""
    def native(a):
        a = np.asarray(a)
        return a.astype(a.dtype.newbyteorder("=")) if a.dtype.byteorder not in "=|" else a

    triangles = {}
    for name, per_block in data.cell_data.items():
        parts = [per_block[i] for i, c in enumerate(data.cells) if c.type == "triangle"]
        parts += [np.concatenate([per_block[i]] * 2) for i, c in enumerate(data.cells) if c.type == "quad"]
        if all(np.ndim(p) == 1 for p in parts):
            triangles[name] = native(np.concatenate(parts))
    vertices = {name: native(a) for name, a in data.point_data.items() if np.ndim(a) == 1}
    return {"vertex_attributes": vertices, "triangle_attributes": triangles}


@reader([".gltf", ".glb"], kind="mesh", description="glTF 2.0 triangle mesh read with trimesh")
def read_gltf(path) -> TerrainMesh:
    """Read every triangle mesh of the default scene, node transforms applied, back to z up.

    glTF's Y-up frame is turned back into CRS axes (``x, -z, y``), so a
    file written by :func:`write_gltf` reads back in world coordinates (to
    float32 precision relative to its origin).  The CRS comes from the scene
    extras (``crs``) or a ``.prj`` sidecar.
    """
    import trimesh

    path = Path(path)
    with quiet():
        scene = trimesh.load_scene(path, process=False)
    vertices, triangles, offset = [], [], 0
    for node in scene.graph.nodes_geometry:
        transform, name = scene.graph[node]
        geom = scene.geometry.get(name)
        if not isinstance(geom, trimesh.Trimesh) or len(geom.faces) == 0:
            continue
        vertices.append(trimesh.transform_points(np.asarray(geom.vertices, dtype=np.float64), transform))
        triangles.append(np.asarray(geom.faces, dtype=np.int64) + offset)
        offset += len(geom.vertices)
    if not triangles:
        raise InvalidInputError(f"{str(path)!r} holds no triangle meshes")
    extras = scene.metadata if isinstance(scene.metadata, dict) else {}
    crs = extras.get("crs")
    crs = to_wkt(crs) if isinstance(crs, str) and crs else sidecar_crs(path)
    return mesh_from_arrays(path, _from_y_up(np.concatenate(vertices)), triangles, crs=crs)
