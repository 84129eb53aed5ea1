"""Vectors as users have them, on real DEMs: streams in another datum reaching beyond the DEM (issue 42).

For each DEM (Big Tujunga, WGS 84 / UTM 11N; St. Helens, the sample) a
stream network (:func:`tinsmith.shapes.stream_network`: descent paths, 1 km
beyond the DEM where they reach its edge, a line across it, one leaving and
entering again, one wholly outside) is written on another datum (NAD27 for
Big Tujunga's WGS 84 zone, NAD83 for St. Helens' NAD27 one) and in WGS 84
geographic; ``tinsmith simplify`` meshes the DEM with ``greedy`` and
``quality`` with and without the lines, writing 2DM.  Each row: exit code,
the note and warning lines, whether every clipped stream lies along the 2DM's
node strings (every point of it within half a cell diagonal of one: the snap
to the nearest cell centre), the largest vertical error and smallest
plan-view angle with and without lines, triangles below the angle bound (at
input angles, reported by the method), and the times.

    python benchmarks/vector_inputs.py            # writes benchmarks/RESULTS_vectors.md (about 3 minutes)
"""

from __future__ import annotations

import json
import subprocess
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from _common import SHARED, ST_HELENS, machine  # noqa: E402

DEMS = {
    "Big Tujunga (30 m, 643 x 1197)": (SHARED / "data/terrain/big_tujunga_canyon/srtm_bigtujunga30m_utm11.tif", 5.0),
    "St. Helens (30 m, 468 x 327)": (ST_HELENS, 2.0),
}
DATUMS = {"another datum, UTM (same zone)": None, "WGS 84 geographic": "EPSG:4326"}


def write_streams(hf, path: Path, crs: str) -> None:
    from pyproj import Transformer

    from tinsmith.shapes import stream_network

    move = Transformer.from_crs(hf.crs, crs, always_xy=True)
    doc = {"type": "FeatureCollection", "features": [
        {"type": "Feature", "properties": {}, "geometry": {
            "type": "LineString", "coordinates": np.column_stack(move.transform(xy[:, 0], xy[:, 1])).tolist()}}
        for xy in stream_network(hf)]}
    if crs != "EPSG:4326":
        doc["crs"] = {"type": "name", "properties": {"name": crs}}
    path.write_text(json.dumps(doc))


def other_datum(hf) -> str:
    """The DEM's UTM zone on another datum: NAD27 (EPSG 267zz) for a WGS 84 zone, NAD83 (269zz) for a NAD27 one."""
    from pyproj import CRS

    epsg = CRS.from_user_input(hf.crs).to_epsg()
    return f"EPSG:{(26900 if 26700 < epsg < 26800 else 26700) + epsg % 100}"


def run(dem: Path, method: str, error: float, out: Path, lines: Path | None):
    args = [sys.executable, "-m", "tinsmith", "simplify", str(dem), "--method", method, "--max-error", str(error),
            "-o", str(out), "--json"]
    if lines is not None:
        args += ["--breaklines", str(lines)]
    start = time.perf_counter()
    done = subprocess.run(args, capture_output=True, text=True)
    elapsed = time.perf_counter() - start
    summary = json.loads(done.stdout) if done.returncode == 0 else {}
    return done.returncode, [x for x in done.stderr.splitlines() if x.strip()], summary, elapsed


def along_node_strings(mesh, fitted, cell: float) -> tuple[int, float]:
    """(how many fitted lines lie along the node strings, the largest distance of a point of one to them)."""
    import shapely

    network = shapely.MultiLineString([mesh.vertices[ids, :2] for ids in mesh.node_strings.values()
                                       if len(ids) > 1])
    worst, good = 0.0, 0
    for line in fitted:
        dense = shapely.segmentize(shapely.LineString(line), cell / 4)
        far = float(shapely.distance(network, shapely.points(shapely.get_coordinates(dense))).max())
        worst = max(worst, far)
        good += far <= cell * np.sqrt(0.5) + 1e-6
    return good, worst


def main() -> None:
    import tinsmith
    from tinsmith.io.geometry import prepare
    from tinsmith.metrics import mesh_metrics
    from tinsmith.metrics.quality import triangle_angles

    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        for name, (dem, error) in DEMS.items():
            hf = tinsmith.read_heightfield(dem)
            cell = float(np.sqrt(abs(hf.transform[0] * hf.transform[4] - hf.transform[1] * hf.transform[3])))
            for method in ("greedy", "quality"):
                plain_out = tmp / "plain.2dm"
                code, _, plain_summary, plain_time = run(dem, method, error, plain_out, None)
                assert code == 0
                plain = tinsmith.read(plain_out)
                plain_angle = float(triangle_angles(plain, 2).min())
                plain_err = mesh_metrics(plain, hf)["vertical_error"]["max"]
                for datum, crs in DATUMS.items():
                    lines = tmp / "streams.geojson"
                    write_streams(hf, lines, crs or other_datum(hf))
                    out = tmp / "mesh.2dm"
                    code, err, summary, elapsed = run(dem, method, error, out, lines)
                    with warnings.catch_warnings():
                        warnings.simplefilter("ignore")
                        fitted = prepare("lines", lines, hf, "breaklines")
                    mesh = tinsmith.read(out)
                    good, worst = along_node_strings(mesh, fitted, cell)
                    q = summary.get("quality", {})
                    rows.append({
                        "dem": name, "method": method, "datum": datum, "exit": code,
                        "notes": sum(x.startswith("tinsmith: note:") for x in err),
                        "warnings": sum(x.startswith("tinsmith: warning:") for x in err),
                        "warning": next((x.split("': ", 1)[-1] for x in err if "warning" in x), ""),
                        "along": f"{good} of {len(fitted)}", "worst": worst / cell,
                        "err": mesh_metrics(mesh, hf)["vertical_error"]["max"], "plain_err": plain_err,
                        "angle": float(triangle_angles(mesh, 2).min()), "plain_angle": plain_angle,
                        "below": q.get("below_min_angle", 0), "n_tri": mesh.n_triangles,
                        "time": elapsed, "plain_time": plain_time,
                    })
                    print(rows[-1], flush=True)
    lines = [
        "# Vectors as users have them: streams in another datum reaching 1 km beyond the DEM",
        "",
        machine(),
        "",
        "`python benchmarks/vector_inputs.py`. Streams: `tinsmith.shapes.stream_network` (descent paths, 1 km beyond "
        "the DEM where they reach its edge, a line across it and 1 km past both sides, one leaving and entering "
        "again, one wholly outside), written on another datum (the DEM's UTM zone in NAD27 for Big Tujunga, NAD83 for "
        "St. Helens) or in WGS 84 geographic. *Along*: clipped "
        "streams every point of which lies within half a cell diagonal of the 2DM's node strings (the snap to the "
        "nearest cell centre), and the largest such distance in cells. *Below*: triangles under the angle bound, at "
        "input angles where two streams, or a stream and the edge, meet tighter (reported by the method).",
        "",
        "| DEM | method | streams in | exit | notes / warnings | the warning | along | farthest (cells) | max error "
        "(without lines) | min angle (without) | below | triangles | time s (without) |",
        "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |",
    ]
    for r in rows:
        lines.append(
            f"| {r['dem']} | {r['method']} | {r['datum']} | {r['exit']} | {r['notes']} / {r['warnings']} | "
            f"{r['warning']} | {r['along']} | {r['worst']:.3f} | {r['err']:.3g} ({r['plain_err']:.3g}) | "
            f"{r['angle']:.1f} ({r['plain_angle']:.1f}) | {r['below']} | {r['n_tri']:,} | "
            f"{r['time']:.1f} ({r['plain_time']:.1f}) |")
    (HERE / "RESULTS_vectors.md").write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
