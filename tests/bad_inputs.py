"""The inputs of the bad-input catalog (tests/test_bad_inputs.py): small, made here, one folder.

Every file is tiny (at most 32 x 32 cells, a few hundred points) so that the
whole catalog runs in seconds once the kernels are compiled.
"""

from __future__ import annotations

import json
from functools import partial
from pathlib import Path

import numpy as np

from .conftest import write_las, write_tif

W, H = 24, 20
TRANSFORM = (5.0, 0.0, 500000.0, 0.0, -5.0, 4100100.0)


def heights(rows: int = H, cols: int = W) -> np.ndarray:
    r, c = np.mgrid[0:rows, 0:cols]
    return (50 + 8 * np.sin(r / 4.0) * np.cos(c / 5.0) + 0.4 * r + 0.2 * c).astype(np.float32)


#: A GeoTIFF of the catalog: the shared writer on the catalog's grid (TRANSFORM) unless a case gives another.
tif = partial(write_tif, transform=TRANSFORM)


def geojson(path: Path, geometries: list, crs: str | None = None) -> Path:
    """A FeatureCollection of ``geometries`` (None: a feature without geometry)."""
    doc = {"type": "FeatureCollection",
           "features": [{"type": "Feature", "properties": {"id": i}, "geometry": g} for i, g in enumerate(geometries)]}
    if crs:
        doc["crs"] = {"type": "name", "properties": {"name": crs}}
    path.write_text(json.dumps(doc))
    return path


def cloud_xyz(path: Path, xyz: np.ndarray) -> Path:
    np.savetxt(path, xyz, fmt="%.6f")
    return path


def degrees_las(path: Path, lon, lat, z) -> Path:
    """A LAS file of points in WGS 84 degrees (EPSG:4326), stored to 1e-7 degrees (about 1 cm)."""
    return write_las(path, np.column_stack([lon, lat, z]), crs="EPSG:4326", scales=(1e-7, 1e-7, 0.001))


def terrain_cloud(n: int = 600, seed: int = 1) -> np.ndarray:
    rng = np.random.default_rng(seed)
    xy = rng.uniform(0, 60, (n, 2)) + [500000, 4100000]
    return np.column_stack([xy, 30 + np.sin(xy[:, 0] / 7) * 2 + 0.1 * (xy[:, 1] - 4100000)])


def write_obj(path: Path, vertices, faces) -> Path:
    lines = [f"v {x} {y} {z}" for x, y, z in vertices]
    lines += ["f " + " ".join(str(i + 1) for i in f) for f in faces]
    path.write_text("\n".join(lines) + "\n")
    return path


#: The geometry of each kind of vector option, in the DEM's CRS (EPSG:32610), inside both the DEM and the cloud.
SHAPES = {
    "line": [{"type": "LineString", "coordinates": [[500010.0, 4100010.0], [500030.0, 4100035.0], [500050.0, 4100045.0]]}],
    "point": [{"type": "MultiPoint", "coordinates": [[500020.0, 4100020.0], [500030.0, 4100040.0]]}],
    "polygon": [{"type": "Polygon", "coordinates": [[[500015.0, 4100015.0], [500035.0, 4100015.0],
                                                     [500035.0, 4100035.0], [500015.0, 4100035.0],
                                                     [500015.0, 4100015.0]]]}],
}
#: What each vector variant of the catalog is (see :func:`vector_variants`).
VARIANTS = ("other-datum", "other-projection", "no-crs", "no-crs-far", "partly-outside", "entirely-outside",
            "crossing", "empty-feature", "invalid")


def _moved(geometry: dict, move) -> dict:
    """A GeoJSON geometry with every coordinate pair passed through ``move(x, y) -> (x, y)``."""
    def walk(c):
        if isinstance(c[0], (int, float)):
            return list(move(*c[:2]))
        return [walk(x) for x in c]

    return {"type": geometry["type"], "coordinates": walk(geometry["coordinates"])}


def _variant(kind: str, variant: str) -> tuple[list, str | None]:
    """(geometries, CRS) of one vector variant; CRS None writes a file without one."""
    from pyproj import Transformer

    utm = "urn:ogc:def:crs:EPSG::32610"
    base = SHAPES[kind]
    if variant == "other-datum":  # NAD27 / UTM 10N: a datum shift of some 100 m
        move = Transformer.from_crs("EPSG:32610", "EPSG:26710", always_xy=True).transform
        return [_moved(g, move) for g in base], "urn:ogc:def:crs:EPSG::26710"
    if variant == "other-projection":  # geographic WGS 84
        move = Transformer.from_crs("EPSG:32610", "EPSG:4326", always_xy=True).transform
        return [_moved(g, move) for g in base], "urn:ogc:def:crs:OGC:1.3:CRS84"
    if variant == "no-crs":
        return base, None
    if variant == "no-crs-far":
        return [_moved(g, lambda x, y: (x - 500000.0, y - 4100000.0)) for g in base], None
    if variant == "partly-outside":  # reaches 300 m beyond the data
        extra = {"line": [{"type": "LineString", "coordinates": [[500020.0, 4100020.0], [500300.0, 4100300.0]]}],
                 "point": [{"type": "Point", "coordinates": [500400.0, 4100400.0]}],
                 "polygon": [{"type": "Polygon", "coordinates": [[[500030.0, 4100030.0], [500400.0, 4100030.0],
                                                                  [500400.0, 4100400.0], [500030.0, 4100030.0]]]}]}
        return base + extra[kind], utm
    if variant == "entirely-outside":
        return [_moved(g, lambda x, y: (x + 5000.0, y + 5000.0)) for g in base], utm
    if variant == "crossing":  # a second copy turned about the middle: lines cross, polygons overlap
        return base + [_moved(g, lambda x, y: (1000060.0 - x, y)) for g in base], utm
    if variant == "empty-feature":
        return base + [None], utm
    # invalid: a line of one point (GEOS cannot build it), and for polygons a bow tie
    bad = {"polygon": {"type": "Polygon", "coordinates": [[[500012.0, 4100012.0], [500040.0, 4100040.0],
                                                           [500040.0, 4100012.0], [500012.0, 4100040.0],
                                                           [500012.0, 4100012.0]]]}}
    return base + [bad.get(kind, {"type": "LineString", "coordinates": [[500020.0, 4100020.0]]})], utm


def vector_variants(root: Path) -> dict[str, Path]:
    """``{kind}_{variant}`` vector files for the matrix of the catalog: GeoJSON, or a shapefile without a
    ``.prj`` where the variant has no CRS (a GeoJSON without one is WGS 84 by definition)."""
    import pyogrio
    import shapely

    out = {}
    for kind in SHAPES:
        for variant in VARIANTS:
            geoms, crs = _variant(kind, variant)
            stem = f"{kind}_{variant.replace('-', '_')}"
            if crs is None:
                path = root / f"{stem}.shp"
                wkb = np.array([shapely.to_wkb(shapely.geometry.shape(g)) for g in geoms], dtype=object)
                pyogrio.raw.write(str(path), wkb, [], [], geometry_type={"line": "LineString", "point": "MultiPoint",
                                                                     "polygon": "Polygon"}[kind], crs=None,
                              driver="ESRI Shapefile")
            else:
                path = geojson(root / f"{stem}.geojson", geoms, crs)
            out[f"{kind}_{variant}"] = path
    return out


def make_inputs(root: Path) -> dict[str, Path]:
    """Every input of the catalog, by name."""
    import tinsmith

    root.mkdir(parents=True, exist_ok=True)
    f: dict[str, Path] = {}
    z = heights()
    f["dem"] = tif(root / "dem.tif", z)
    f["dem_nodata"] = tif(root / "dem_nodata.tif", np.where(np.add.outer(range(H), range(W)) < 6, -9999, z),
                          nodata=-9999.0)
    f["all_nodata"] = tif(root / "all_nodata.tif", np.full((H, W), -9999.0, np.float32), nodata=-9999.0)
    f["one_cell"] = tif(root / "one_cell.tif", z[:1, :1])
    f["one_row"] = tif(root / "one_row.tif", z[:1, :])
    f["constant"] = tif(root / "constant.tif", np.full((H, W), 12.5, np.float32))
    spike = z.copy()
    spike[7, 9] = 1e30
    f["spike"] = tif(root / "spike.tif", spike)
    nan = z.copy()
    nan[3:6, 4:8] = np.nan
    f["undeclared_nan"] = tif(root / "undeclared_nan.tif", nan)
    inf = z.copy()
    inf[2, 2] = np.inf
    f["undeclared_inf"] = tif(root / "undeclared_inf.tif", inf)
    s16 = np.round(z).astype(np.int16)
    s16[:2, :3] = -32768
    f["int16_sentinel"] = tif(root / "int16_sentinel.tif", s16)
    s9999 = z.copy()
    s9999[10:12, 10:12] = -9999
    f["sentinel_9999"] = tif(root / "sentinel_9999.tif", s9999)
    f["rotated"] = tif(root / "rotated.tif", z, transform=(4.33, 2.5, 500000.0, 2.5, -4.33, 4100100.0))
    f["south_up"] = tif(root / "south_up.tif", z, transform=(5.0, 0.0, 500000.0, 0.0, 5.0, 4100000.0))
    f["geographic"] = tif(root / "geographic.tif", z, transform=(0.0001, 0.0, 13.4, 0.0, -0.0001, 52.5),
                          crs="EPSG:4326")
    f["no_crs"] = tif(root / "no_crs.tif", z, crs=None)
    # cells of 4.0037 x 4.0139 m (an ordinary resample: within 1% of square) and of 4 x 4.2 m (5% off)
    f["cells_near_square"] = tif(root / "cells_near_square.tif", z,
                                 transform=(4.0037, 0.0, 500000.0, 0.0, -4.0139, 4100100.0))
    f["cells_not_square"] = tif(root / "cells_not_square.tif", z, transform=(4.0, 0.0, 500000.0, 0.0, -4.2, 4100100.0))
    f["no_georef"] = tif(root / "no_georef.tif", z, transform=None, crs=None)
    np.save(root / "heights.npy", z)
    f["npy"] = root / "heights.npy"
    # an ASCII grid with its .prj sidecar (an output dem_asc.ply would write dem_asc.prj)
    import rasterio
    from rasterio.transform import Affine

    with rasterio.open(root / "dem_asc.asc", "w", driver="AAIGrid", width=W, height=H, count=1, dtype="float32",
                       transform=Affine(5, 0, 500000, 0, -5, 4100100), crs="EPSG:32610") as ds:
        ds.write(z, 1)
    f["asc"] = root / "dem_asc.asc"
    f["asc_prj"] = root / "dem_asc.prj"
    # point clouds
    cloud = terrain_cloud()
    f["cloud"] = cloud_xyz(root / "cloud.xyz", cloud)
    f["cloud_las"] = write_las(root / "cloud.las", cloud, classes=np.full(len(cloud), 2, np.uint8))
    f["empty_las"] = write_las(root / "empty.las", np.zeros((0, 3)))
    f["one_xy"] = cloud_xyz(root / "one_xy.xyz", np.column_stack([np.full(50, 500010.0), np.full(50, 4100010.0),
                                                                  np.linspace(0, 5, 50)]))
    t = np.linspace(0, 50, 80)
    f["collinear"] = cloud_xyz(root / "collinear.xyz", np.column_stack([500000 + t, 4100000 + 2 * t, 10 + t / 10]))
    nan_cloud = cloud.copy()
    nan_cloud[5, 0] = np.nan
    (root / "nan_cloud.xyz").write_text("\n".join(" ".join(f"{v:.6f}" if np.isfinite(v) else "nan" for v in p)
                                                  for p in nan_cloud) + "\n")
    f["nan_cloud"] = root / "nan_cloud.xyz"
    f["duplicates"] = cloud_xyz(root / "duplicates.xyz", np.tile([[500001.0, 4100002.0, 7.0]], (40, 1)))
    # meshes
    hf = tinsmith.read_heightfield(f["dem"])
    mesh = tinsmith.simplify(hf, method="greedy", max_error=1.0)
    tinsmith.write(mesh, root / "mesh.ply")
    f["mesh"] = root / "mesh.ply"
    v = [(0, 0, 0), (10, 0, 1), (10, 10, 2), (0, 10, 1)]
    f["bad_index"] = write_obj(root / "bad_index.obj", v, [(0, 1, 2), (0, 2, 7)])
    f["nan_vertex"] = write_obj(root / "nan_vertex.obj", [(0, 0, 0), (10, 0, float("nan")), (10, 10, 2), (0, 10, 1)],
                                [(0, 1, 2), (0, 2, 3)])
    fan = [(0, 0, 0), (10, 0, 0), (0, 10, 0), (-10, 0, 0), (0, -10, 0), (0, 0, 10)]
    f["non_manifold"] = write_obj(root / "non_manifold.obj", fan, [(0, 1, 2), (0, 2, 1), (0, 1, 5), (0, 3, 4)])
    f["quads"] = write_obj(root / "quads.obj", v, [(0, 1, 2, 3)])
    f["no_faces"] = write_obj(root / "no_faces.obj", v, [])
    # vectors (in the DEM's CRS unless said otherwise: a GeoJSON without 'crs' is WGS 84)
    x0, y0 = 500010.0, 4100010.0
    utm = "urn:ogc:def:crs:EPSG::32610"
    f["breakline"] = geojson(root / "breakline.geojson",
                             [{"type": "LineString", "coordinates": [[x0, y0], [x0 + 60, y0 + 50]]}], utm)
    f["stream"] = geojson(root / "stream.geojson",  # across the DEM, west to east: an inflow and an outflow
                          [{"type": "LineString", "coordinates": [[x0 - 50, y0 + 40], [x0 + 150, y0 + 45]]}], utm)
    f["one_point_line"] = geojson(root / "one_point_line.geojson",
                                  [{"type": "LineString", "coordinates": [[x0, y0]]}], utm)
    f["empty_vector"] = geojson(root / "empty.geojson", [])
    f["line_other_crs"] = geojson(root / "line_other_crs.geojson",
                                  [{"type": "LineString", "coordinates": [[13.4, 52.5], [13.41, 52.51]]}],
                                  crs="urn:ogc:def:crs:OGC:1.3:CRS84")
    f["line_far_away"] = geojson(root / "line_far_away.geojson",
                                 [{"type": "LineString", "coordinates": [[100.0, 100.0], [200.0, 300.0]]}], utm)
    f["polygon_far_away"] = geojson(root / "polygon_far_away.geojson", [{"type": "Polygon", "coordinates": [
        [[100.0, 100.0], [200.0, 100.0], [200.0, 200.0], [100.0, 100.0]]]}], utm)
    f["points"] = geojson(root / "points.geojson", [{"type": "Point", "coordinates": [x0 + 20, y0 + 20]}], utm)
    bowtie = [[[x0, y0], [x0 + 40, y0 + 40], [x0 + 40, y0], [x0, y0 + 40], [x0, y0]]]
    f["bowtie"] = geojson(root / "bowtie.geojson", [{"type": "Polygon", "coordinates": bowtie}], utm)
    f["landuse"] = geojson(root / "landuse.geojson", [{"type": "Polygon", "coordinates": [
        [[x0, y0], [x0 + 40, y0], [x0 + 40, y0 + 40], [x0, y0 + 40], [x0, y0]]]}], utm)
    f["landuse_wgs84"] = geojson(root / "landuse_wgs84.geojson", [{"type": "Polygon", "coordinates": [
        [[-123.0, 37.04], [-122.99, 37.04], [-122.99, 37.05], [-123.0, 37.05], [-123.0, 37.04]]]}])
    f.update(vector_variants(root))
    # damaged, empty and truncated files of every readable format
    for suffix in (".tif", ".asc", ".npy", ".npz", ".png", ".las", ".laz", ".xyz", ".ply", ".obj", ".stl", ".off",
                   ".vtk", ".vtu", ".msh", ".gltf", ".glb", ".2dm", ".landxml", ".geojson"):
        stem = suffix[1:]
        (root / f"empty_{stem}{suffix}").write_bytes(b"")
        f[f"empty{suffix}"] = root / f"empty_{stem}{suffix}"
        (root / f"garbage_{stem}{suffix}").write_bytes(np.random.default_rng(len(suffix)).bytes(3000))
        f[f"garbage{suffix}"] = root / f"garbage_{stem}{suffix}"
    good = {".tif": f["dem"], ".npy": f["npy"], ".las": f["cloud_las"], ".xyz": f["cloud"], ".ply": f["mesh"]}
    for fmt in (".obj", ".stl", ".vtk", ".2dm", ".landxml", ".glb"):
        tinsmith.write(mesh, root / f"whole{fmt}")
        good[fmt] = root / f"whole{fmt}"
    write_las(root / "whole.laz", cloud)
    good[".laz"] = root / "whole.laz"
    for suffix, path in good.items():
        data = path.read_bytes()
        cut = len(data) // 2
        if suffix == ".xyz":  # cut inside a line, after its x: a line of one number
            cut = data.index(b" ", data.index(b"\n", cut) + 1)
        (root / f"truncated_{suffix[1:]}{suffix}").write_bytes(data[:cut])
        f[f"truncated{suffix}"] = root / f"truncated_{suffix[1:]}{suffix}"
    f.update(more_inputs(root, z, cloud, f["cloud_las"]))
    return f


def more_inputs(root: Path, z: np.ndarray, cloud: np.ndarray, cloud_las: Path) -> dict[str, Path]:
    """Several bands, a LAS cut at a record boundary, folders of clouds, a cloud in another CRS or in degrees,
    a terrarium tile."""
    import laspy
    import rasterio
    from rasterio.transform import Affine

    f = {}
    with rasterio.open(root / "three_bands.tif", "w", driver="GTiff", width=W, height=H, count=3, dtype="float32",
                       transform=Affine(*TRANSFORM), crs="EPSG:32610") as ds:
        for b in range(3):
            ds.write(z + 100 * b, b + 1)
    f["three_bands"] = root / "three_bands.tif"
    head = laspy.open(cloud_las).header  # 400 of the 600 announced points: laspy alone reads 400 in silence
    f["cut_las"] = root / "cut_at_record.las"
    f["cut_las"].write_bytes(cloud_las.read_bytes()[: head.offset_to_point_data + 400 * head.point_format.size])
    (root / "survey").mkdir()
    write_las(root / "survey" / "a.las", cloud[:300])
    write_las(root / "survey" / "b.las", cloud[300:])
    f["survey"] = root / "survey"
    (root / "empty_folder").mkdir()
    f["empty_folder"] = root / "empty_folder"
    f["other_crs_las"] = write_las(root / "other_crs.las", cloud, crs="EPSG:32611")
    f["geographic_las"] = degrees_las(root / "geographic.las", 13.4 + (cloud[:, 0] - 500000) * 1e-5,  # near Berlin
                                      52.5 + (cloud[:, 1] - 4100000) * 1e-5, cloud[:, 2])
    v = z.astype(np.float64) + 32768.0  # a terrarium tile (its name gives the encoding and z/x/y)
    rgb = np.stack([np.floor(v / 256), np.floor(v) % 256, np.floor((v - np.floor(v)) * 256)]).astype(np.uint8)
    with rasterio.open(root / "terrarium_z11_385_803.png", "w", driver="PNG", width=W, height=H, count=3,
                       dtype="uint8") as ds:
        ds.write(rgb)
    f["terrarium_png"] = root / "terrarium_z11_385_803.png"
    return f
