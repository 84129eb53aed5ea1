"""The bad-input catalog: damaged files, odd rasters, clouds, meshes, vectors, hostile options, bad outputs.

Each case runs one command through the real entry point (``main``) or one call
of the public API, and checks the contract of docs/bad-input.md:

* exit code 1 with exactly one line on standard error that names the file or
  the option (``error``), or exit code 0 with exactly one ``tinsmith: warning:``
  line (``warning``), one ``tinsmith: note:`` line (``note``: vectors
  reprojected) or none (``ok``), and the outputs written;
* never a traceback or an internal error;
* after a failure, no output and no temporary file in the output folder;
* every input file byte for byte as before (hashed);
* no hang: a fault-handler guard aborts the run if one case takes minutes.

In the arguments, ``@name`` is an input of :func:`tests.bad_inputs.make_inputs`
and ``%name`` a file in the case's own empty output folder.
"""

from __future__ import annotations

import contextlib
import hashlib
import math
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

import tinsmith
from tinsmith.algorithms.lod import levels_of_detail
from tinsmith.cli.main import main
from tinsmith.errors import ResourceError, TinsmithError, TinsmithWarning

from .bad_inputs import VARIANTS, heights, make_inputs
from .conftest import hang_guard

ERROR, WARNING, OK, NOTE = "error", "warning", "ok", "note"
NOTE_WARNING = "note+warning"  # vectors reprojected (a note), then something about them (a warning)


def case(id, expect, needle, *args, outputs=()):
    return pytest.param(expect, needle, list(args), list(outputs), id=id)


# -- damaged, empty and truncated files of every readable format -------------------------
FORMATS = (".tif", ".asc", ".npy", ".npz", ".png", ".las", ".laz", ".xyz", ".ply", ".obj", ".stl", ".off", ".vtk",
           ".vtu", ".msh", ".gltf", ".glb", ".2dm", ".landxml")
DAMAGED = [case(f"empty{s}", ERROR, f"empty_{s[1:]}{s}", "info", f"@empty{s}") for s in FORMATS]
DAMAGED += [case(f"garbage{s}", ERROR, f"garbage_{s[1:]}{s}", "simplify", f"@garbage{s}", "-o", "%m.ply",
                 "--cell-size", "5") if s == ".npy" else
            case(f"garbage{s}", ERROR, f"garbage_{s[1:]}{s}", "simplify", f"@garbage{s}", "-o", "%m.ply")
            for s in FORMATS]
TRUNCATED = (".tif", ".npy", ".las", ".laz", ".ply", ".obj", ".stl", ".vtk", ".2dm", ".landxml", ".glb")
DAMAGED += [case(f"truncated{s}", ERROR, f"truncated_{s[1:]}{s}", "info", f"@truncated{s}") for s in TRUNCATED]
DAMAGED += [
    # a text cloud cut in the middle of a line: the last line has two numbers
    case("truncated.xyz", ERROR, "truncated_xyz.xyz", "info", "@truncated.xyz"),
    case("missing-file", ERROR, "nope.tif", "simplify", "nope.tif", "-o", "%m.ply"),
    case("folder-as-input", ERROR, "out", "info", "%"),
    case("empty-breaklines", ERROR, "empty.geojson", "simplify", "@dem", "-o", "%m.ply", "--breaklines", "@empty_vector"),
    case("garbage-landuse", ERROR, "garbage_geojson.geojson", "wavelet", "@dem", "-o", "%m.ply",
         "--landuse", "@garbage.geojson"),
]

# -- rasters ------------------------------------------------------------------------------
RASTERS = [
    case("all-nodata", ERROR, "all_nodata.tif", "simplify", "@all_nodata", "-o", "%m.ply"),
    case("one-cell", ERROR, "one_cell.tif", "simplify", "@one_cell", "-o", "%m.ply"),
    case("one-row", ERROR, "one_row.tif", "simplify", "@one_row", "-o", "%m.ply"),
    case("constant", OK, "", "simplify", "@constant", "-o", "%m.ply", outputs=["m.ply"]),
    case("constant-quadtree", OK, "", "simplify", "@constant", "-o", "%m.ply", "--method", "quadtree",
         outputs=["m.ply"]),
    case("constant-cvt", OK, "", "simplify", "@constant", "-o", "%m.ply", "--method", "cvt", "--max-vertices", "30",
         outputs=["m.ply"]),
    case("constant-remesh", OK, "", "remesh", "@constant", "-o", "%m.ply", "--vertices", "60", outputs=["m.ply"]),
    case("spike-1e30", ERROR, "--nodata 1e+30", "simplify", "@spike", "-o", "%m.ply"),
    case("spike-1e30-declared", OK, "", "simplify", "@spike", "-o", "%m.ply", "--nodata", "1e30", outputs=["m.ply"]),
    case("undeclared-nan", ERROR, "--nodata nan", "simplify", "@undeclared_nan", "-o", "%m.ply"),
    case("undeclared-nan-declared", OK, "", "simplify", "@undeclared_nan", "-o", "%m.ply", "--nodata", "nan",
         outputs=["m.ply"]),
    case("undeclared-inf", ERROR, "undeclared_inf.tif", "simplify", "@undeclared_inf", "-o", "%m.ply"),
    case("int16-sentinel", WARNING, "--nodata -32768", "simplify", "@int16_sentinel", "-o", "%m.ply",
         outputs=["m.ply"]),
    case("sentinel-9999", WARNING, "--nodata -9999", "simplify", "@sentinel_9999", "-o", "%m.ply",
         outputs=["m.ply"]),
    case("sentinel-9999-declared", OK, "", "simplify", "@sentinel_9999", "-o", "%m.ply", "--nodata", "-9999",
         outputs=["m.ply"]),
    case("rotated", OK, "", "simplify", "@rotated", "-o", "%m.ply", outputs=["m.ply"]),
    case("south-up", OK, "", "simplify", "@south_up", "-o", "%m.ply", outputs=["m.ply"]),
    case("geographic", WARNING, "geographic", "simplify", "@geographic", "-o", "%m.ply", outputs=["m.ply"]),
    case("geographic-tile", WARNING, "geographic", "tile", "@geographic", "-o", "%m.ply", "--max-error", "1",
         "--tile-size", "16", "--workers", "1", outputs=["m.ply"]),
    case("no-crs", OK, "", "simplify", "@no_crs", "-o", "%m.ply", outputs=["m.ply"]),
    case("no-georeferencing", ERROR, "--cell-size", "simplify", "@no_georef", "-o", "%m.ply"),
    case("npy-without-cell-size", ERROR, "--cell-size", "simplify", "@npy", "-o", "%m.ply"),
    case("npy-with-cell-size", OK, "", "simplify", "@npy", "-o", "%m.ply", "--cell-size", "5", outputs=["m.ply"]),
    case("band-beyond-count", ERROR, "band", "simplify", "@dem", "-o", "%m.ply", "--band", "3"),
    # several bands: band 1 with a warning, unless --band says which
    case("bands-three", WARNING, "3 bands", "simplify", "@three_bands", "-o", "%m.ply", outputs=["m.ply"]),
    case("bands-band-2", OK, "", "simplify", "@three_bands", "-o", "%m.ply", "--band", "2", outputs=["m.ply"]),
    case("bands-band-0", ERROR, "--band", "simplify", "@three_bands", "-o", "%m.ply", "--band", "0"),
    case("bands-band-4", ERROR, "the file has 3 bands", "simplify", "@three_bands", "-o", "%m.ply", "--band", "4"),
    case("bands-tile", WARNING, "3 bands", "tile", "@three_bands", "-o", "%m.ply", "--max-error", "1", "--workers",
         "1", outputs=["m.ply"]),
    case("bands-tile-band-2", OK, "", "tile", "@three_bands", "-o", "%m.ply", "--max-error", "1", "--workers", "1",
         "--band", "2", outputs=["m.ply"]),
    case("bands-urban-tiled-band", ERROR, "--band", "city", "@three_bands", "-o", "%m.ply", "--tile-size", "64",
         "--band", "2"),
    case("terrarium-png-no-band-warning", OK, "", "info", "@terrarium_png"),
    # a DSM in degrees: refused before anything is allocated, naming the CRS and the UTM zone to go to
    case("urban-geographic", ERROR, "EPSG:4326", "city", "@geographic", "-o", "%m.ply"),
    case("urban-geographic-levels", ERROR, "EPSG:32633", "city", "@geographic", "-o", "%m.ply", "--roofs", "levels"),
    case("urban-geographic-tiled", ERROR, "EPSG:4326", "city", "@geographic", "-o", "%m.ply", "--tile-size", "64",
         "--workers", "1"),
    # a DEM in degrees for the flood method, whose flow and time step are metres: refused naming the UTM zone
    case("flood-geographic", ERROR, "EPSG:32633", "simplify", "@geographic", "-o", "%m.2dm", "--method", "flood"),
    case("nodata-not-a-number", ERROR, "--nodata", "simplify", "@dem", "-o", "%m.ply", "--nodata", "abc"),
]

# -- point clouds ------------------------------------------------------------------------
CLOUDS = [
    case("cloud-no-points", ERROR, "empty.las", "simplify", "@empty_las", "-o", "%m.ply"),
    case("cloud-no-points-reconstruct", ERROR, "empty.las", "reconstruct", "@empty_las", "-o", "%m.ply"),
    case("cloud-one-xy", ERROR, "one_xy.xyz", "simplify", "@one_xy", "-o", "%m.ply"),
    case("cloud-one-xy-reconstruct", ERROR, "one_xy.xyz", "reconstruct", "@one_xy", "-o", "%m.ply"),
    case("cloud-collinear", ERROR, "collinear.xyz", "simplify", "@collinear", "-o", "%m.ply"),
    case("cloud-collinear-reconstruct", ERROR, "collinear.xyz", "reconstruct", "@collinear", "-o", "%m.ply"),
    case("cloud-nan", ERROR, "nan_cloud.xyz", "simplify", "@nan_cloud", "-o", "%m.ply"),
    case("cloud-nan-reconstruct", ERROR, "nan_cloud.xyz", "reconstruct", "@nan_cloud", "-o", "%m.ply"),
    case("cloud-duplicates-only", ERROR, "duplicates.xyz", "reconstruct", "@duplicates", "-o", "%m.ply"),
    case("cloud-class-keeps-nothing", ERROR, "cloud.las", "simplify", "@cloud_las", "-o", "%m.ply", "--classes", "9"),
    case("cloud-classes-not-numbers", ERROR, "--classes", "simplify", "@cloud_las", "-o", "%m.ply", "--classes", "a,b"),
    # lines in WGS 84 near Berlin, the cloud in California: reprojected, and found to lie wholly outside
    case("cloud-other-crs-breaklines", NOTE_WARNING, "entirely outside", "simplify", "@cloud_las", "-o", "%m.ply",
         "--breaklines", "@line_other_crs", outputs=["m.ply"]),
    case("cloud-gridded", OK, "", "simplify", "@cloud_las", "-o", "%m.ply", outputs=["m.ply"]),
    # a LAS cut at a record boundary: the header's count against what is there, everywhere
    case("cloud-cut-at-a-record", ERROR, "holds 400 points but its header announces 600", "info", "@cut_las"),
    case("cloud-cut-at-a-record-simplify", ERROR, "cut_at_record.las", "simplify", "@cut_las", "-o", "%m.ply"),
    case("cloud-cut-at-a-record-reconstruct", ERROR, "cut_at_record.las", "reconstruct", "@cut_las", "-o", "%m.ply"),
    case("cloud-cut-at-a-record-in-a-list", ERROR, "cut_at_record.las", "simplify", "@cloud_las", "@cut_las", "-o",
         "%m.ply"),
    # many files: a folder, a glob, a list
    case("clouds-folder", OK, "", "reconstruct", "@survey", "-o", "%m.ply", outputs=["m.ply"]),
    case("clouds-glob", OK, "", "simplify", "@survey:/*.las", "-o", "%m.ply", outputs=["m.ply"]),
    case("clouds-glob-matching-nothing", ERROR, "no file matches", "simplify", "@empty_folder:/*.laz", "-o",
         "%m.ply"),
    case("clouds-empty-folder", ERROR, "empty_folder", "simplify", "@empty_folder", "-o", "%m.ply"),
    case("clouds-other-crs", ERROR, "different CRSs", "simplify", "@cloud_las", "@other_crs_las", "-o", "%m.ply"),
    case("clouds-other-crs-reconstruct", ERROR, "other_crs.las", "reconstruct", "@cloud_las", "@other_crs_las", "-o",
         "%m.ply"),
    case("urban-geographic-cloud", ERROR, "geographic.las", "city", "@geographic_las", "-o", "%m.ply"),
    case("reconstruct-geographic-cloud", WARNING, "geographic", "reconstruct", "@geographic_las", "-o", "%m.ply",
         outputs=["m.ply"]),
    case("cloud-reconstructed", OK, "", "reconstruct", "@cloud", "-o", "%m.ply", outputs=["m.ply"]),
]

# -- meshes --------------------------------------------------------------------------------
MESHES = [
    case("mesh-bad-index", ERROR, "bad_index.obj", "remesh", "@bad_index", "-o", "%m.ply", "--vertices", "10"),
    case("mesh-nan-vertex", ERROR, "nan_vertex.obj", "remesh", "@nan_vertex", "-o", "%m.ply", "--vertices", "10"),
    case("mesh-non-manifold", ERROR, "non_manifold", "remesh", "@non_manifold", "-o", "%m.ply", "--vertices", "10"),
    case("mesh-quads", OK, "", "info", "@quads"),
    case("mesh-no-faces", ERROR, "no_faces.obj", "remesh", "@no_faces", "-o", "%m.ply", "--vertices", "10"),
    case("mesh-bad-index-metrics", ERROR, "bad_index.obj", "metrics", "@bad_index", "@dem"),
    case("mesh-as-dem", ERROR, "mesh.ply", "simplify", "@mesh", "-o", "%m.ply"),
    case("dem-as-mesh", ERROR, "dem.tif", "metrics", "@dem", "@dem"),
    case("mesh-view-nan", ERROR, "nan_vertex.obj", "view", "@nan_vertex", "-o", "%v.html"),
    case("cloud-as-mesh", ERROR, "cloud.xyz", "view", "@cloud", "-o", "%v.html"),
]

# -- vectors -------------------------------------------------------------------------------
VECTORS = [
    case("breakline-one-point", ERROR, "one_point_line.geojson", "simplify", "@dem", "-o", "%m.ply",
         "--breaklines", "@one_point_line"),
    case("breakline-one-point-remesh", ERROR, "one_point_line.geojson", "remesh", "@dem", "-o", "%m.ply",
         "--vertices", "100", "--breaklines", "@one_point_line"),
    case("breakline-one-point-cvt", ERROR, "one_point_line.geojson", "simplify", "@dem", "-o", "%m.ply",
         "--method", "cvt", "--max-vertices", "50", "--breaklines", "@one_point_line"),
    case("breakline-other-crs", NOTE_WARNING, "line_other_crs.geojson", "simplify", "@dem", "-o", "%m.ply",
         "--breaklines", "@line_other_crs", outputs=["m.ply"]),
    case("breakline-no-overlap", WARNING, "entirely outside", "simplify", "@dem", "-o", "%m.ply",
         "--breaklines", "@line_far_away", outputs=["m.ply"]),
    case("breaklines-are-points", ERROR, "points.geojson", "simplify", "@dem", "-o", "%m.ply",
         "--breaklines", "@points"),
    case("control-points-empty", ERROR, "empty.geojson", "simplify", "@dem", "-o", "%m.ply",
         "--control-points", "@empty_vector"),
    case("breakline-ok", OK, "", "simplify", "@dem", "-o", "%m.ply", "--breaklines", "@breakline", outputs=["m.ply"]),
    case("landuse-invalid-polygon", WARNING, "self-intersecting repaired", "wavelet", "@dem", "-o", "%m.ply",
         "--landuse", "@bowtie", "--role", "bowtie:water", outputs=["m.ply"]),
    case("landuse-no-overlap", WARNING, "polygon_far_away", "wavelet", "@dem", "-o", "%m.ply", "--landuse",
         "@polygon_far_away", "--role", "polygon_far_away:water", outputs=["m.ply"]),
    case("landuse-no-role", WARNING, "role", "wavelet", "@dem", "-o", "%m.ply", "--landuse", "@landuse",
         outputs=["m.ply"]),
    case("landuse-empty", ERROR, "empty.geojson", "wavelet", "@dem", "-o", "%m.ply", "--landuse", "@empty_vector"),
    # land use in another CRS is reprojected (documented), a line layer has no polygon
    case("landuse-other-crs", NOTE, "reprojected from", "wavelet", "@dem", "-o", "%m.ply", "--landuse",
         "@landuse_wgs84", "--role", "landuse_wgs84:water", outputs=["m.ply"]),
    case("landuse-of-lines", ERROR, "breakline.geojson", "wavelet", "@dem", "-o", "%m.ply", "--landuse",
         "@breakline", "--role", "breakline:water"),
    # solver boundary segments (tinsmith.segment_outline)
    case("streams-missing", ERROR, "--streams", "simplify", "@dem", "-o", "%m.2dm", "--streams", "nope.geojson"),
    case("streams-no-lines", ERROR, "--streams", "simplify", "@dem", "-o", "%m.2dm", "--streams", "@points"),
    case("streams-empty", ERROR, "--streams", "simplify", "@dem", "-o", "%m.2dm", "--streams", "@empty_vector"),
    case("boundary-without-equals", ERROR, "--boundary", "simplify", "@dem", "-o", "%m.2dm", "--boundary",
         "@breakline"),
    case("boundary-empty-name", ERROR, "--boundary", "simplify", "@dem", "-o", "%m.2dm", "--boundary",
         "=@breakline"),
    case("boundary-missing", ERROR, "--boundary", "simplify", "@dem", "-o", "%m.2dm", "--boundary",
         "weir=nope.geojson"),
    case("streams-ok", OK, "", "simplify", "@dem", "-o", "%m.2dm", "--method", "quality", "--max-error", "1",
         "--streams", "@stream",
         "--boundary", "weir=@breakline", outputs=["m.2dm"]),
    case("streams-ply-note", NOTE, "only to 2DM", "simplify", "@dem", "-o", "%m.ply", "--streams", "@stream",
         outputs=["m.ply"]),
]

# -- every vector option x what users' vectors are like (tests/bad_inputs.py: vector_variants) --------------
#: option -> (kind of geometry, the command before the file, what follows it)
VECTOR_OPTIONS = {
    "breaklines": ("line", ["simplify", "@dem", "-o", "%m.ply", "--breaklines"], []),
    "breaklines-quality": ("line", ["simplify", "@dem", "-o", "%m.ply", "--method", "quality", "--max-error", "1",
                                    "--breaklines"], []),
    "breaklines-remesh": ("line", ["remesh", "@dem", "-o", "%m.ply", "--vertices", "80", "--breaklines"], []),
    "breaklines-cloud": ("line", ["simplify", "@cloud_las", "-o", "%m.ply", "--breaklines"], []),
    "control-points": ("point", ["simplify", "@dem", "-o", "%m.ply", "--control-points"], []),
    "regions": ("polygon", ["simplify", "@dem", "-o", "%m.ply", "--method", "quality", "--max-error", "1",
                            "--regions"], []),
    "holes": ("polygon", ["simplify", "@cloud_las", "-o", "%m.ply", "--holes"], []),
    "flat": ("polygon", ["simplify", "@cloud_las", "-o", "%m.ply", "--flat"], []),
    "footprints": ("polygon", ["city", "@dem", "-o", "%m.ply", "--footprints"], []),
    "landuse": ("polygon", ["wavelet", "@dem", "-o", "%m.ply", "--landuse"], ["--role", "{stem}:water"]),
}


def _expected(kind: str, option: str, variant: str) -> tuple[str, str]:
    """(expect, needle) of one vector option x variant: docs/bad-input.md, "Vector inputs"."""
    if variant in ("other-datum", "other-projection"):
        return NOTE, "reprojected from"
    if variant == "no-crs-far":
        return ERROR, "do not overlap"
    if variant == "partly-outside":
        if option == "landuse":  # land use is kept whole: only features entirely outside are dropped
            return OK, ""
        return WARNING, "entirely outside" if kind == "point" else "clipped"
    if variant == "entirely-outside":
        return WARNING, "entirely outside"
    if variant == "empty-feature":
        return WARNING, "empty or invalid skipped"
    if variant == "invalid":
        return WARNING, "self-intersecting repaired" if kind == "polygon" else "empty or invalid skipped"
    return OK, ""  # no-crs (taken in the data's coordinates: they overlap), crossing


VECTOR_MATRIX = []
for option, (kind, before, after) in VECTOR_OPTIONS.items():
    for variant in VARIANTS:
        expect, needle = _expected(kind, option, variant)
        stem = f"{kind}_{variant.replace('-', '_')}"
        VECTOR_MATRIX.append(case(f"{option}:{variant}", expect, needle, *before, f"@{kind}_{variant}",
                                  *(a.format(stem=stem) for a in after),
                                  outputs=["m.ply"] if expect != ERROR else []))

# -- numeric options -------------------------------------------------------------------------
NUMBERS = []
for value, expect in (("0", OK), ("-1", ERROR), ("nan", ERROR), ("inf", ERROR), ("1e308", OK)):
    NUMBERS.append(case(f"max-error={value}", expect, "max_error" if expect == ERROR else "",
                        "simplify", "@dem", "-o", "%m.ply", "--max-error", value,
                        outputs=["m.ply"] if expect == OK else []))
for value, expect in (("0", ERROR), ("-1", ERROR), ("1000000000000", OK)):
    NUMBERS.append(case(f"max-vertices={value}", expect, "max_vertices" if expect == ERROR else "",
                        "simplify", "@dem", "-o", "%m.ply", "--max-vertices", value,
                        outputs=["m.ply"] if expect == OK else []))
for value in ("0", "-5"):
    NUMBERS.append(case(f"max-triangles={value}", ERROR, "max_triangles", "simplify", "@dem", "-o", "%m.ply",
                        "--max-triangles", value))
NUMBERS += [
    case("max-vertices-not-int", ERROR, "--max-vertices", "simplify", "@dem", "-o", "%m.ply", "--max-vertices", "1.5"),
    case("quadtree-max-error-nan", ERROR, "max_error", "simplify", "@dem", "-o", "%m.ply", "--method", "quadtree",
         "--max-error", "nan"),
    # quality: the largest accepted angle finishes; beyond it, one line (docs/methods/quality.md: the guards)
    case("quality-min-angle=33", OK, "", "simplify", "@dem", "-o", "%m.ply", "--method", "quality",
         "--min-angle", "33", outputs=["m.ply"]),
    case("quality-min-angle=34", ERROR, "min_angle", "simplify", "@dem", "-o", "%m.ply", "--method", "quality",
         "--min-angle", "34"),
    case("quality-cells-within-1pct", OK, "", "simplify", "@cells_near_square", "-o", "%m.ply", "--method",
         "quality", outputs=["m.ply"]),
    case("quality-cells-not-square", ERROR, "4 x 4.2", "simplify", "@cells_not_square", "-o", "%m.ply",
         "--method", "quality"),
    case("cvt-ratio=0", ERROR, "ratio", "simplify", "@dem", "-o", "%m.ply", "--method", "cvt", "--ratio", "0"),
    case("cvt-ratio=2", ERROR, "ratio", "simplify", "@dem", "-o", "%m.ply", "--method", "cvt", "--ratio", "2"),
    case("cvt-max-vertices-huge", OK, "", "simplify", "@dem", "-o", "%m.ply", "--method", "cvt",
         "--max-vertices", "9223372036854775807", outputs=["m.ply"]),
    case("subsample-step=0", ERROR, "step", "simplify", "@dem", "-o", "%m.ply", "--method", "subsample", "--step", "0"),
    case("features-max-vertices=2", ERROR, "max_vertices", "simplify", "@dem", "-o", "%m.ply", "--method", "features",
         "--max-vertices", "2"),
    case("cell-size=0", ERROR, "cell_size", "simplify", "@npy", "-o", "%m.ply", "--cell-size", "0"),
    case("cell-size=-1", ERROR, "cell_size", "simplify", "@npy", "-o", "%m.ply", "--cell-size", "-1"),
    case("cell-size=nan", ERROR, "cell_size", "simplify", "@npy", "-o", "%m.ply", "--cell-size", "nan"),
    case("cloud-cell-size-tiny", ERROR, "cell_size", "simplify", "@cloud", "-o", "%m.ply", "--cell-size", "1e-300"),
    case("tile-size=0", ERROR, "--tile-size", "tile", "@dem", "-o", "%m.ply", "--max-error", "1", "--tile-size", "0"),
    case("tile-size=-1", ERROR, "--tile-size", "tile", "@dem", "-o", "%m.ply", "--max-error", "1", "--tile-size", "-1"),
    case("tile-size-huge", OK, "", "tile", "@dem", "-o", "%m.ply", "--max-error", "1", "--tile-size", "1000000000",
         "--workers", "1", outputs=["m.ply"]),
    case("tile-workers=0", ERROR, "--workers", "tile", "@dem", "-o", "%m.ply", "--max-error", "1", "--workers", "0"),
    case("tile-max-error=0", ERROR, "max_error", "tile", "@dem", "-o", "%m.ply", "--max-error", "0"),
    case("tile-max-error=nan", ERROR, "max_error", "tile", "@dem", "-o", "%m.ply", "--max-error", "nan"),
    # a tiled run that fails before any tile leaves nothing (no parts folder, no job file)
    case("tile-unreachable-scheduler", ERROR, "Dask scheduler", "tile", "@dem", "-o", "%m.ply", "--max-error", "1",
         "--scheduler", "tcp://127.0.0.1:1"),
    case("pyramid-unreachable-scheduler", ERROR, "Dask scheduler", "tile", "@dem", "-o", "%qm", "--max-error", "1",
         "--format", "quantized-mesh", "--scheduler", "tcp://127.0.0.1:1"),
    case("tile-cloud-unreachable-scheduler", ERROR, "Dask scheduler", "tile", "@cloud_las", "-o", "%m.ply",
         "--max-error", "1", "--scheduler", "tcp://127.0.0.1:1"),
    case("tile-halo=0", ERROR, "--halo", "tile", "@dem", "-o", "%m.ply", "--max-error", "1", "--halo", "0"),
    # web terrain: a water file that is not there, the point clouds' water class on a DEM, metadata above level 0,
    # and the quantized-mesh options on 3D Tiles terrain: one line each, no folder left
    case("pyramid-water-missing", ERROR, "nope.gpkg", "tile", "@dem", "-o", "%qm", "--max-error", "1",
         "--format", "quantized-mesh", "--water", "%nope.gpkg"),
    case("pyramid-water-class-on-a-dem", ERROR, "point clouds", "tile", "@dem", "-o", "%qm", "--max-error", "1",
         "--format", "quantized-mesh", "--water", "class"),
    case("pyramid-metadata-min-zoom", ERROR, "min_zoom=0", "tile", "@dem", "-o", "%qm", "--max-error", "1",
         "--format", "quantized-mesh", "--metadata", "--min-zoom", "12"),
    case("3dtiles-water", ERROR, "--water", "tile", "@dem", "-o", "%t3", "--max-error", "1",
         "--format", "3dtiles-terrain", "--water", "flat"),
    case("remesh-vertices=0", ERROR, "--vertices", "remesh", "@dem", "-o", "%m.ply", "--vertices", "0"),
    case("remesh-vertices=-1", ERROR, "--vertices", "remesh", "@dem", "-o", "%m.ply", "--vertices", "-1"),
    case("remesh-vertices=1e9", ERROR, "memory", "remesh", "@dem", "-o", "%m.ply", "--vertices", "1000000000"),
    case("remesh-gamma=nan", ERROR, "gamma", "remesh", "@dem", "-o", "%m.ply", "--vertices", "100", "--gamma", "nan"),
    case("remesh-gamma=inf", ERROR, "gamma", "remesh", "@dem", "-o", "%m.ply", "--vertices", "100", "--gamma", "inf"),
    case("remesh-iterations=-1", ERROR, "iterations", "remesh", "@dem", "-o", "%m.ply", "--vertices", "100",
         "--iterations", "-1"),
    case("reconstruct-mu=0", ERROR, "mu", "reconstruct", "@cloud", "-o", "%m.ply", "--mu", "0"),
    case("reconstruct-mu=nan", ERROR, "mu", "reconstruct", "@cloud", "-o", "%m.ply", "--mu", "nan"),
    case("reconstruct-dexel=0", ERROR, "dexel_size", "reconstruct", "@cloud", "-o", "%m.ply", "--dexel-size", "0"),
    case("reconstruct-dexel-tiny", ERROR, "dexel_size", "reconstruct", "@cloud", "-o", "%m.ply",
         "--dexel-size", "5e-324"),
    case("reconstruct-max-angle=-1", ERROR, "max_angle", "reconstruct", "@cloud", "-o", "%m.ply", "--mode", "general",
         "--max-angle", "-1"),
    case("urban-lod=0", ERROR, "lod", "city", "@dem", "-o", "%m.ply", "--roofs", "levels", "--lod", "0"),
    case("urban-noise-factor=-1", ERROR, "noise", "city", "@dem", "-o", "%m.ply", "--roofs", "levels",
         "--noise-factor", "-1"),
    case("urban-min-width=nan", ERROR, "min_width", "city", "@dem", "-o", "%m.ply", "--roofs", "levels",
         "--min-width", "nan"),
    case("urban-thesis-option-flat", ERROR, "roofs 'levels'", "city", "@dem", "-o", "%m.ply", "--lod", "3"),
    case("urban-roof-height", ERROR, "roof statistic", "city", "@dem", "-o", "%m.ply", "--roof-height", "p200"),
    case("urban-base-above-ground", ERROR, "base height", "city", "@dem", "-o", "%m.stl", "--solid",
         "--base-height", "1e6"),
    case("urban-base-without-solid", ERROR, "goes with solid", "city", "@dem", "-o", "%m.stl", "--base-height", "0"),
    case("urban-solid-levels", ERROR, "solid needs roofs", "city", "@dem", "-o", "%m.stl", "--roofs", "levels", "--solid"),
    case("urban-margin=-1", ERROR, "margin", "city", "@dem", "-o", "%m.ply", "--margin", "-1"),
    case("urban-min-height=nan", ERROR, "min_height", "city", "@dem", "-o", "%m.ply", "--min-height", "nan"),
    case("urban-ground-window=0", ERROR, "ground_window", "city", "@dem", "-o", "%m.ply", "--ground-window", "0"),
    case("wavelet-max-error=0", ERROR, "max_error", "wavelet", "@dem", "-o", "%m.ply", "--landuse", "@landuse",
         "--max-error", "0"),
    case("wavelet-max-error=nan", ERROR, "max_error", "wavelet", "@dem", "-o", "%m.ply", "--landuse", "@landuse",
         "--max-error", "nan"),
    case("lod-repeated-level", ERROR, "--levels", "lod", "@dem", "-o", "%levels", "--levels", "5,20,5"),
    case("lod-empty-levels", ERROR, "--levels", "lod", "@dem", "-o", "%levels", "--levels", ","),
    case("lod-levels-not-numbers", ERROR, "--levels", "lod", "@dem", "-o", "%levels", "--levels", "a,b"),
    case("lod-negative-level", ERROR, "max_error", "lod", "@dem", "-o", "%levels", "--levels", "5,-1"),
    case("lod-vertices=0", ERROR, "max_vertices", "lod", "@dem", "-o", "%levels", "--vertices", "0"),
    case("lod-ok", OK, "", "lod", "@dem", "-o", "%levels", "--levels", "20,5,1", outputs=["levels/index.json"]),
    case("view-exaggeration=0", ERROR, "--exaggeration", "view", "@mesh", "-o", "%v.html", "--exaggeration", "0"),
    case("report-detail-inverted", ERROR, "--detail", "report", "@dem", "@mesh", "-o", "%r.html",
         "--detail", "10,10,0,0"),
    case("compare-no-rule", ERROR, "--max-error", "compare", "@dem"),
    case("unknown-method", ERROR, "nope", "simplify", "@dem", "-o", "%m.ply", "--method", "nope"),
    case("option-of-another-method", ERROR, "step", "simplify", "@dem", "-o", "%m.ply", "--step", "2"),
]

# -- output paths -------------------------------------------------------------------------------
OUTPUTS = [
    case("output-is-the-input", ERROR, "dem.tif", "simplify", "@dem", "-o", "@dem"),
    case("output-sidecar-of-the-input", ERROR, "dem_asc.prj", "simplify", "@asc", "-o", "@asc_prj:ply"),
    case("output-is-the-breakline-file", ERROR, "breakline.geojson", "simplify", "@dem", "-o", "@breakline",
         "--breaklines", "@breakline"),
    case("output-is-the-landuse-file", ERROR, "landuse.geojson", "wavelet", "@dem", "-o", "@landuse",
         "--landuse", "@landuse"),
    case("tile-output-is-the-input", ERROR, "dem.tif", "tile", "@dem", "-o", "@dem", "--max-error", "1"),
    case("remesh-output-is-the-input", ERROR, "mesh.ply", "remesh", "@mesh", "-o", "@mesh", "--vertices", "20"),
    case("report-output-is-an-input", ERROR, "html", "report", "@dem", "@mesh", "-o", "@mesh"),
    case("same-output-twice", ERROR, "m.ply", "simplify", "@dem", "-o", "%m.ply", "-o", "%m.ply"),
    case("missing-folder", ERROR, "missing", "simplify", "@dem", "-o", "%missing/m.ply"),
    case("folder-under-a-file", ERROR, "dem.tif", "simplify", "@dem", "-o", "@dem:/m.ply"),
    case("output-is-a-folder", ERROR, "out", "simplify", "@dem", "-o", "%"),
    case("unknown-suffix", ERROR, "m.xyz", "simplify", "@dem", "-o", "%m.xyz"),
    case("no-suffix", ERROR, "mesh", "simplify", "@dem", "-o", "%mesh"),
    case("lod-output-is-a-file", ERROR, "dem.tif", "lod", "@dem", "-o", "@dem", "--levels", "5"),
    case("parts-folder-with-data", ERROR, "parts folder", "tile", "@dem", "-o", "%m.ply", "--max-error", "1",
         "--parts", "@landuse:.."),
    case("two-formats-one-sidecar", OK, "", "simplify", "@dem", "-o", "%m.ply", "-o", "%m.obj",
         outputs=["m.ply", "m.obj", "m.prj"]),
    # a solver format judges the triangles' shape: greedy's slivers are named, with the method that avoids them
    case("slivers-greedy-2dm", WARNING, "--method quality", "simplify", "@dem", "-o", "%m.2dm", "--method", "greedy",
         outputs=["m.2dm", "m.prj"]),
    case("slivers-greedy-fort14", WARNING, "under 10 degrees", "simplify", "@dem", "-o", "%fort.14", "--method",
         "greedy", outputs=["fort.14", "fort.prj"]),
    case("slivers-greedy-slf", WARNING, "under 10 degrees", "simplify", "@dem", "-o", "%m.slf", "--method", "greedy",
         outputs=["m.slf", "m.cli", "m.prj"]),
    case("slivers-greedy-ply", OK, "", "simplify", "@dem", "-o", "%m.ply", "--method", "greedy", outputs=["m.ply"]),
    case("slivers-none-quality-2dm", OK, "", "simplify", "@dem", "-o", "%m.2dm", "--method", "quality",
         outputs=["m.2dm", "m.prj"]),
]

CATALOG = DAMAGED + RASTERS + CLOUDS + MESHES + VECTORS + VECTOR_MATRIX + NUMBERS + OUTPUTS


@pytest.fixture(scope="module")
def inputs(tmp_path_factory):
    root = tmp_path_factory.mktemp("bad_inputs")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        files = make_inputs(root / "in")
    return root, files


def _hashes(folder: Path) -> dict:
    return {p: hashlib.sha256(p.read_bytes()).hexdigest() for p in sorted(folder.rglob("*")) if p.is_file()}


def _resolve(arg: str, files: dict, out: Path) -> str:
    """``@name`` an input (``@name:ply`` with another suffix, ``@name:/x`` a path below it, ``@name:..`` its
    folder), ``%name`` a path in the output folder (``%`` the folder itself); ``NAME=@name`` a named input."""
    if "=@" in arg and not arg.startswith("@"):
        name, _, rest = arg.partition("=")
        return f"{name}={_resolve(rest, files, out)}"
    if arg.startswith("@"):
        name, _, tail = arg[1:].partition(":")
        path = files[name]
        if tail == "..":
            return str(path.parent)
        if tail.startswith("/"):
            return str(path) + tail
        return str(path.with_suffix("." + tail)) if tail else str(path)
    if arg.startswith("%"):
        return str(out / arg[1:]) if len(arg) > 1 else str(out)
    return arg


@contextlib.contextmanager
def _connect_timeout(timeout):
    """Dask's connect timeout set to ``timeout`` (None: left alone): an unreachable scheduler fails that soon."""
    if timeout is None:
        yield
        return
    import dask
    import distributed  # noqa: F401  (its defaults loaded first: set() within would drop them on leaving)

    with dask.config.set({"distributed.comm.timeouts.connect": timeout}):
        yield


@pytest.mark.parametrize("expect, needle, args, outputs", CATALOG)
def test_bad_input(inputs, tmp_path, capsys, expect, needle, args, outputs):
    root, files = inputs
    out = tmp_path / "out"
    out.mkdir()
    argv = [_resolve(a, files, out) for a in args]
    before = _hashes(root / "in")
    with hang_guard(300), _connect_timeout("2s" if "--scheduler" in args else None):
        code = main(argv)
    captured = capsys.readouterr()
    lines = [line for line in captured.err.splitlines() if line.strip()]
    assert "Traceback" not in captured.err and "internal error" not in captured.err, captured.err
    if expect == ERROR:
        assert code == 1, (code, captured.err)
        assert len(lines) == 1 and "error:" in lines[0], captured.err
        assert needle in lines[0], (needle, lines[0])
        assert sorted(p.name for p in out.iterdir()) == [], "left behind after a failure"
    else:
        assert code == 0, captured.err
        if expect in (WARNING, NOTE):
            assert len(lines) == 1 and lines[0].startswith(f"tinsmith: {expect}:"), captured.err
            assert needle in lines[0], (needle, lines[0])
        elif expect == NOTE_WARNING:
            assert len(lines) == 2 and lines[0].startswith("tinsmith: note:"), captured.err
            assert lines[1].startswith("tinsmith: warning:") and needle in lines[1], (needle, captured.err)
        else:
            assert lines == [], captured.err
        for name in outputs:
            assert (out / name).exists(), name
        assert not [p for p in out.rglob(".*")], "temporary files left"
    assert _hashes(root / "in") == before, "an input changed"


# -- the public API --------------------------------------------------------------------------------
def _api_cases(files, tmp):
    hf = tinsmith.read_heightfield(files["dem"])
    mesh = tinsmith.read_mesh(files["mesh"])
    return {
        "read-missing": (lambda: tinsmith.read(tmp / "nope.tif"), "nope.tif"),
        "read-garbage": (lambda: tinsmith.read(files["garbage.ply"]), "garbage_ply.ply"),
        "read-heightfield-of-a-mesh": (lambda: tinsmith.read_heightfield(files["mesh"]), "mesh.ply"),
        "read-mesh-of-a-raster": (lambda: tinsmith.read_mesh(files["dem"]), "dem.tif"),
        "unknown-method": (lambda: tinsmith.simplify(hf, method="nope"), "nope"),
        "negative-max-error": (lambda: tinsmith.simplify(hf, max_error=-1), "max_error"),
        "nan-max-error": (lambda: tinsmith.greedy(hf, max_error=math.nan), "max_error"),
        "unknown-option": (lambda: tinsmith.greedy(hf, step=2), "step"),
        "remesh-1e9": (lambda: tinsmith.remesh(hf, max_vertices=10**9), "memory"),
        "heightfield-spike": (lambda: tinsmith.Heightfield(np.where(heights() > 55, 1e30, heights()), cell_size=1),
                              "nodata"),
        "heightfield-1xN": (lambda: tinsmith.Heightfield(np.ones((1, 5)), cell_size=1), "2 x 2"),
        "write-unknown-suffix": (lambda: tinsmith.write(mesh, tmp / "m.abc"), "m.abc"),
        "write-missing-folder": (lambda: tinsmith.write(mesh, tmp / "no" / "m.ply"), "no"),
        "write-tif-without-grid": (lambda: tinsmith.write(mesh, tmp / "m.tif"), "grid"),
        "lod-repeated": (lambda: levels_of_detail(hf, "greedy", max_errors=[5, 1, 5]), "max_error"),
        "reconstruct-dexel-0": (lambda: tinsmith.reconstruct(tinsmith.read(files["cloud"]), dexel_size=0),
                                "dexel_size"),
        "read-cut-las": (lambda: tinsmith.read(files["cut_las"]), "holds 400 points but its header announces 600"),
        "read-list-with-a-cut-las": (lambda: tinsmith.read([files["cloud_las"], files["cut_las"]]),
                                     "cut_at_record.las"),
        "read-glob-matching-nothing": (lambda: tinsmith.read(str(files["empty_folder"] / "*.laz")), "no file matches"),
        "read-empty-folder": (lambda: tinsmith.read(files["empty_folder"]), "empty_folder"),
        "read-clouds-other-crs": (lambda: tinsmith.read([files["cloud_las"], files["other_crs_las"]]),
                                  "different CRSs"),
        "read-folder-with-band": (lambda: tinsmith.read(files["survey"], band=2), "'band' does not apply"),
        "read-band-0": (lambda: tinsmith.read(files["three_bands"], band=0), "band"),
        "read-band-4": (lambda: tinsmith.read(files["three_bands"], band=4), "the file has 3 bands"),
        "urban-geographic": (lambda: tinsmith.blocks(tinsmith.read_heightfield(files["geographic"])), "EPSG:4326"),
        "city-geographic": (lambda: tinsmith.city(tinsmith.read_heightfield(files["geographic"])), "EPSG:32633"),
        "breaklines-no-crs-far": (lambda: tinsmith.simplify(hf, breaklines=np.array([[0.0, 0.0], [10.0, 10.0]])),
                                  "do not overlap the data"),
        "regions-not-a-polygon": (lambda: tinsmith.simplify(hf, method="quality", regions=[("x", 1.0)]),
                                  "regions[0] must be a polygon"),
    }


API_CASES = ["read-missing", "read-garbage", "read-heightfield-of-a-mesh", "read-mesh-of-a-raster", "unknown-method",
             "negative-max-error", "nan-max-error", "unknown-option", "remesh-1e9", "heightfield-spike",
             "heightfield-1xN", "write-unknown-suffix", "write-missing-folder", "write-tif-without-grid",
             "lod-repeated", "reconstruct-dexel-0", "read-cut-las", "read-list-with-a-cut-las",
             "read-glob-matching-nothing", "read-empty-folder", "read-clouds-other-crs", "read-folder-with-band",
             "read-band-0", "read-band-4", "urban-geographic", "city-geographic", "breaklines-no-crs-far",
             "regions-not-a-polygon"]


@pytest.mark.parametrize("name", API_CASES)
def test_bad_input_through_the_api(inputs, tmp_path, name):
    root, files = inputs
    call, needle = _api_cases(files, tmp_path)[name]
    with hang_guard(300), pytest.raises(TinsmithError) as info:
        call()
    assert needle in str(info.value) and "\n" not in str(info.value)
    assert list(tmp_path.iterdir()) == []
    if name == "remesh-1e9":
        assert isinstance(info.value, ResourceError) and isinstance(info.value, MemoryError)


def test_api_warns_about_an_undeclared_sentinel_and_a_geographic_crs(inputs):
    _, files = inputs
    with pytest.warns(TinsmithWarning, match="--nodata -9999"):
        tinsmith.read_heightfield(files["sentinel_9999"])
    with pytest.warns(TinsmithWarning, match="geographic"):
        tinsmith.read_heightfield(files["geographic"])


def test_the_installed_script_keeps_the_contract(inputs, tmp_path):
    """The four cases of the issue through the real ``tinsmith`` process: one line, exit 1, nothing changed."""
    root, files = inputs
    before = _hashes(root / "in")
    for argv, needle in (
        (["simplify", files["dem"], "-o", files["dem"]], "is the input"),
        (["remesh", files["dem"], "-o", tmp_path / "r.ply", "--vertices", "1000000000"], "memory"),
        (["simplify", files["dem"], "-o", tmp_path / "m.ply", "--breaklines", files["one_point_line"]],
         "one_point_line.geojson"),
        (["simplify", files["spike"], "-o", tmp_path / "m.ply"], "--nodata 1e+30"),
        (["lod", files["dem"], "-o", tmp_path / "levels", "--levels", "5,20,5"], "more than once"),
    ):
        done = subprocess.run([sys.executable, "-m", "tinsmith", *map(str, argv)], capture_output=True, text=True,
                              timeout=300)
        lines = done.stderr.strip().splitlines()
        assert done.returncode == 1 and len(lines) == 1 and needle in lines[0], (argv, done.stderr)
    assert list(tmp_path.iterdir()) == []
    assert _hashes(root / "in") == before


def test_api_reads_a_folder_a_glob_and_a_list_of_clouds_alike(inputs):
    _, files = inputs
    survey = files["survey"]
    counts = {len(tinsmith.read(x)) for x in (survey, str(survey / "*.las"), sorted(survey.glob("*.las")))}
    assert counts == {600}


def test_the_catalog_has_at_least_150_cases():
    assert len(CATALOG) + len(API_CASES) >= 150
