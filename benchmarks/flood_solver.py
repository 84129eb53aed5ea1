"""Meshes judged by a shallow-water solver: ANUGA rain-on-grid runs on simplified meshes against the full grid.

    python benchmarks/flood_solver.py                      # writes benchmarks/RESULTS_flood.md and docs/img/flood_*.png
    python benchmarks/flood_solver.py --dems bijou helens --sizes 0.02 0.05 0.1

For each DEM the reference is the full-resolution grid mesh (``method="grid"``).  Every mesh (tinsmith's
``flood`` with its defaults, only ``max_error`` chosen for the count, ``quality``, ``greedy``, ``cvt`` and
``remesh`` at a few triangle counts, a share of the reference's, and ANUGA's own Triangle mesh over the
outline of the DEM at flood's counts) is handed to ANUGA with the same
event: uniform rain on every triangle for ``--minutes``, Manning's n, transmissive borders, then a drain-out
time without rain.  Measured per run: solver wall time, steps and mean time step, the final depth against the
reference's at the reference's triangle centroids (RMSE, and the IoU of the cells deeper than 5 cm), the
Nash-Sutcliffe efficiency of the outflow hydrograph (rain added minus the change of stored volume, per
yieldstep) against the reference's, and the mesh's max vertical error against the DEM.

ANUGA (Apache-2.0) installs meshpy, whose bundled Triangle is not free for commercial use: ANUGA's own meshes
are a peer in this benchmark only.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import sys
import time
from pathlib import Path

import numpy as np
from scipy.interpolate import LinearNDInterpolator, NearestNDInterpolator

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from _common import ROOT, SHARED, ST_HELENS, machine  # noqa: E402

sys.path.insert(0, str(ROOT / "src"))
import tinsmith  # noqa: E402
from tinsmith.core import Heightfield  # noqa: E402
from tinsmith.io.boundaries import named_boundaries  # noqa: E402

with contextlib.redirect_stdout(io.StringIO()):  # ANUGA prints a warning on stdout when mpi4py is absent
    import anuga

IMG = ROOT / "docs/img"
DATA = SHARED / "data"
DEMS = {
    # name: (label, path, block-mean factor, window (rows, cols) or None)
    "bijou": ("West Bijou gully", DATA / "terrain/landlab_west_bijou/west_bijou_gully.asc", 1, None),
    "helens": ("St. Helens", ST_HELENS, 1, None),
    "delft": ("Delft DTM", DATA / "urban/delft_ahn3/delft_dtm_0.5m.tif", 1, None),
    "tujunga": ("Big Tujunga", DATA / "terrain/big_tujunga_canyon/srtm_bigtujunga30m_utm11.tif", 1, (1000, 1000)),
}
MESHERS = ("flood", "quality", "greedy", "cvt", "remesh", "anuga")
WET = 0.05  # m: a point is flooded when deeper


def load(name: str, coarsen: int | None) -> tuple[str, Heightfield]:
    label, path, factor, window = DEMS[name]
    factor = coarsen or factor
    hf = tinsmith.read_heightfield(path)
    z = np.asarray(hf.z, float)
    a, b, c, d, e, f = hf.transform[:6]
    if window is not None:
        z = z[: window[0], : window[1]]
        label += f", the first {z.shape[0]} x {z.shape[1]} cells"
    if factor > 1:  # block mean; a block with any nodata cell is nodata
        h, w = (s // factor * factor for s in z.shape)
        z = z[:h, :w].reshape(h // factor, factor, w // factor, factor).mean(axis=(1, 3))
        a, e = a * factor, e * factor
        label += f", {factor}x{factor} block mean"
    return label, Heightfield(z, transform=(a, b, c, d, e, f), crs=hf.crs, nodata=float("nan"))


# -- the meshes ------------------------------------------------------------------------------------------------

def flood_mesh(hf: Heightfield, n: int):
    """``flood`` with its defaults and only ``max_error`` chosen, for about ``n`` triangles: the bound starts at
    greedy insertion's error at ``n`` triangles and is scaled by the count it gave (triangles fall about as
    1 / max_error), at most 8 tries, until within 5%."""
    start = tinsmith.simplify(hf, method="greedy", max_triangles=n)
    error = float(tinsmith.vertical_error(start, hf)["max"])
    best = None
    for _ in range(8):
        mesh = tinsmith.simplify(hf, method="flood", max_error=error)
        if best is None or abs(mesh.n_triangles - n) < abs(best.n_triangles - n):
            best = mesh
        if abs(mesh.n_triangles - n) <= 0.05 * n:
            break
        error *= (mesh.n_triangles / n) ** 0.8
    return best


def tinsmith_mesh(method: str, hf: Heightfield, reference, n: int):
    """A mesh of about ``n`` triangles: the triangle stop rule where the method has one, else the vertex budget
    of ``n / 2`` corrected once by the count it gave (``flood``: :func:`flood_mesh`)."""
    if method == "flood":
        return flood_mesh(hf, n)
    if method in ("quality", "greedy"):
        return tinsmith.simplify(hf, method=method, max_triangles=n)
    data = reference if method == "remesh" else hf
    v = max(n // 2, 8)
    mesh = tinsmith.simplify(data, method=method, max_vertices=v)
    if abs(mesh.n_triangles - n) > 0.05 * n:
        v = max(int(round(v + (n - mesh.n_triangles) / 2)), 8)
        mesh = tinsmith.simplify(data, method=method, max_vertices=v)
    return mesh


def outline(reference) -> np.ndarray:
    """The outer loop of the reference mesh, x-y, counter-clockwise, collinear points dropped."""
    loops = named_boundaries(reference)["outline"]
    best = None
    for loop in loops:
        xy = reference.vertices[loop[:-1], :2]
        x, y = xy[:, 0] - xy[:, 0].mean(), xy[:, 1] - xy[:, 1].mean()
        area = 0.5 * (np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y))
        if area > 0 and (best is None or area > best[0]):
            best = (area, xy)
    xy = best[1]
    prev, nxt = np.roll(xy, 1, axis=0), np.roll(xy, -1, axis=0)
    cross = (xy[:, 0] - prev[:, 0]) * (nxt[:, 1] - xy[:, 1]) - (xy[:, 1] - prev[:, 1]) * (nxt[:, 0] - xy[:, 0])
    return xy[np.abs(cross) > 1e-9]


def anuga_domain(polygon: np.ndarray, area: float, heights, friction: float):
    with contextlib.redirect_stdout(io.StringIO()):
        domain = anuga.create_domain_from_regions(
            [tuple(p) for p in polygon.tolist()], boundary_tags={"exterior": list(range(len(polygon)))},
            maximum_triangle_area=area, use_cache=False, verbose=False)
    xy = domain.get_vertex_coordinates(absolute=True)
    z = heights(xy).reshape(-1, 3)
    domain.set_quantity("elevation", z, location="vertices")
    domain.set_quantity("stage", z, location="vertices")
    domain.set_quantity("friction", friction)
    return domain


def anuga_mesh(polygon, heights, n: int, friction: float, crs):
    """ANUGA's own mesh of about ``n`` triangles (max triangle area from the polygon's area, corrected twice),
    as a domain and as a TerrainMesh for its vertical error."""
    x, y = polygon[:, 0], polygon[:, 1]
    total = 0.5 * abs(np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y))
    area = total / n
    for _ in range(3):
        domain = anuga_domain(polygon, area, heights, friction)
        got = len(domain)
        if abs(got - n) <= 0.05 * n:
            break
        area *= got / n
    nodes = domain.get_nodes(absolute=True)
    mesh = tinsmith.TerrainMesh(np.column_stack([nodes, heights(nodes)]), domain.triangles, crs=crs)
    return domain, mesh


def height_function(reference):
    v = reference.vertices
    lin = LinearNDInterpolator(v[:, :2], v[:, 2])
    near = NearestNDInterpolator(v[:, :2], v[:, 2])

    def heights(xy):
        z = lin(xy)
        bad = np.isnan(z)
        z[bad] = near(xy[bad])
        return z

    return heights


# -- the run ---------------------------------------------------------------------------------------------------

def run(domain, rain: float, rain_s: float, end_s: float, yield_s: float, boundary: str) -> dict:
    domain.set_store(False)
    make = getattr(anuga, boundary)
    bc = make(domain)
    domain.set_boundary({tag: bc for tag in set(domain.boundary.values())})
    anuga.Rate_operator(domain, rate=lambda t: rain if t < rain_s else 0.0)
    area = domain.get_area()
    times, volumes, steps = [0.0], [domain.get_water_volume()], 0
    start = time.perf_counter()
    with contextlib.redirect_stdout(io.StringIO()):
        for t in domain.evolve(yieldstep=yield_s, finaltime=end_s):
            steps += int(domain.number_of_steps)  # counted afresh in every yieldstep
            if float(t) > times[-1]:  # evolve yields the start too
                times.append(float(t))
                volumes.append(domain.get_water_volume())
    seconds = time.perf_counter() - start
    times, volumes = np.array(times), np.array(volumes)
    rained = rain * area * np.minimum(times, rain_s)
    outflow = (np.diff(rained) - np.diff(volumes)) / np.diff(times)  # m3/s leaving over each yieldstep
    q = domain.quantities
    depth = q["stage"].centroid_values - q["elevation"].centroid_values
    xy = domain.centroid_coordinates + [domain.geo_reference.xllcorner, domain.geo_reference.yllcorner]
    finite = all(np.isfinite(q[k].centroid_values).all() for k in ("stage", "xmomentum", "ymomentum"))
    return {"seconds": seconds, "steps": steps, "mean_dt": end_s / max(steps, 1), "outflow": outflow,
            "depth": depth, "xy": xy, "finite": finite, "triangles": len(domain)}


def depth_at(res: dict, points: np.ndarray) -> np.ndarray:
    h = np.maximum(res["depth"], 0.0)
    d = LinearNDInterpolator(res["xy"], h)(points)
    bad = np.isnan(d)
    if bad.any():
        d[bad] = NearestNDInterpolator(res["xy"], h)(points[bad])
    return d


def nse(sim: np.ndarray, obs: np.ndarray) -> float:
    return float(1.0 - np.sum((sim - obs) ** 2) / np.sum((obs - obs.mean()) ** 2))


def iou(a: np.ndarray, b: np.ndarray) -> float:
    wa, wb = a > WET, b > WET
    union = np.sum(wa | wb)
    return float(np.sum(wa & wb) / union) if union else float("nan")


# -- one DEM ---------------------------------------------------------------------------------------------------

def bench(name: str, args) -> tuple[str, list[dict]]:
    label, hf = load(name, args.coarsen.get(name))
    rain = args.rain_mm_h / 1000.0 / 3600.0
    rain_s = args.minutes * 60.0
    end_s = rain_s + args.drain_minutes * 60.0
    event = dict(rain=rain, rain_s=rain_s, end_s=end_s, yield_s=args.yieldstep, boundary=args.boundary)
    reference = tinsmith.simplify(hf, method="grid")
    print(f"{label}: reference {reference.n_triangles} triangles", flush=True)
    points = reference.vertices[:, :2][reference.triangles].mean(axis=1)
    ref = run(reference.to_anuga(friction=args.manning), **event)
    ref_depth = depth_at(ref, points)
    rows = [row("grid (reference)", reference, ref, ref_depth, ref, ref_depth, hf, 0.0)]
    rows[0]["dry_rmse"] = float(np.sqrt(np.mean(ref_depth ** 2)))  # the RMSE of a run that keeps no water at all
    print(rows[-1], flush=True)
    polygon = outline(reference)
    heights = height_function(reference)
    for share in args.sizes:
        n = max(int(round(share * reference.n_triangles)), 20)
        for method in args.meshers:
            t0 = time.perf_counter()
            try:
                if method == "anuga":  # at flood's count, when flood ran at this size
                    flood = [r for r in rows if r["mesher"] == "flood" and r["share"] == share and r.get("triangles")]
                    domain, mesh = anuga_mesh(polygon, heights, flood[0]["triangles"] if flood else n, args.manning,
                                              hf.crs)
                else:
                    mesh = tinsmith_mesh(method, hf, reference, n)
                    domain = mesh.to_anuga(friction=args.manning)
            except Exception as err:  # a mesher that cannot make this size: said in the table
                print(f"  {method} {n}: {type(err).__name__}: {err}", flush=True)
                rows.append({"mesher": method, "share": share, "triangles": None, "error": f"{type(err).__name__}"})
                continue
            mesh_s = time.perf_counter() - t0
            res = run(domain, **event)
            rows.append(row(method, mesh, res, depth_at(res, points), ref, ref_depth, hf, mesh_s, share))
            if method == "flood":
                rows[-1]["max_error_bound"] = mesh.info["max_error_used"]
                rows[-1]["relaxed"] = mesh.info["flood"]["relaxed"]["triangles"]
            print(rows[-1], flush=True)
    return label, rows


def row(mesher, mesh, res, depth, ref, ref_depth, hf, mesh_s, share=1.0) -> dict:
    err = tinsmith.vertical_error(mesh, hf)
    n = min(len(res["outflow"]), len(ref["outflow"]))
    return {"mesher": mesher, "share": share, "triangles": res["triangles"], "mesh_s": mesh_s,
            "seconds": res["seconds"], "steps": res["steps"], "mean_dt": res["mean_dt"],
            "rmse": float(np.sqrt(np.mean((depth - ref_depth) ** 2))), "iou": iou(depth, ref_depth),
            "nse": nse(res["outflow"][:n], ref["outflow"][:n]), "max_error": float(err["max"]),
            "finite": res["finite"], "peak": float(res["outflow"].max())}


# -- output ----------------------------------------------------------------------------------------------------

def table(label: str, rows: list[dict]) -> list[str]:
    out = [f"## {label}", "",
           f"A run that keeps no water anywhere would have a depth RMSE of {rows[0]['dry_rmse']:.4f} m.", "",
           "| mesher | share | triangles | mesh s | solver s | steps | mean dt (s) | depth RMSE (m) | IoU > 5 cm "
           "| outflow NSE | peak outflow (m3/s) | max error (m) |",
           "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
    for r in rows:
        if r.get("triangles") is None:
            out.append(f"| {r['mesher']} | {r['share']:.0%} | failed: {r['error']} | | | | | | | | | |")
            continue
        flag = "" if r["finite"] else " (non-finite values)"
        out.append(
            f"| {r['mesher']}{flag} | {r['share']:.0%} | {r['triangles']:,} | {r['mesh_s']:.1f} | {r['seconds']:.1f} "
            f"| {r['steps']:,} | {r['mean_dt']:.3f} | {r['rmse']:.4f} | {r['iou']:.3f} | {r['nse']:.3f} "
            f"| {r['peak']:.3f} | {r['max_error']:.2f} |")
    return out + [""] + acceptance(rows)


def _curve(rows, mesher):
    return sorted((r["seconds"], r["rmse"]) for r in rows if r["mesher"] == mesher and r.get("triangles")
                  and r["finite"])


def acceptance(rows: list[dict]) -> list[str]:
    """flood against ANUGA's own mesh at flood's count (RMSE and solver-time ratios), flood's RMSE against ANUGA's
    at equal solver time (ANUGA's curve interpolated in log time; '-' outside its range), flood's outflow NSE and
    its share of the reference's triangles."""
    out = ["| size | flood max_error (m) | flood triangles | over the bound | RMSE flood / ANUGA | solver time flood / "
           "ANUGA | RMSE / ANUGA's at equal time | flood outflow NSE | share of the reference's triangles |",
           "| --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
    curve = _curve(rows, "anuga")
    ref = rows[0]["triangles"]
    for f in [r for r in rows if r["mesher"] == "flood" and r.get("triangles")]:
        a = next((r for r in rows if r["mesher"] == "anuga" and r["share"] == f["share"] and r.get("triangles")), None)
        if a is None or not (f["finite"] and a["finite"]):
            continue
        equal = "-"
        if len(curve) > 1 and curve[0][0] <= f["seconds"] <= curve[-1][0]:
            t, e = zip(*curve, strict=True)
            equal = f"{f['rmse'] / np.interp(np.log(f['seconds']), np.log(t), e):.2f}"
        out.append(f"| {f['share']:.0%} | {f['max_error_bound']:.3g} | {f['triangles']:,} | {f['relaxed']:,} "
                   f"| {f['rmse'] / a['rmse']:.2f} | {f['seconds'] / a['seconds']:.2f} | {equal} | {f['nse']:.3f} "
                   f"| {f['triangles'] / ref:.1%} |")
    return out + [""]


def picture(name: str, label: str, rows: list[dict]) -> Path:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(6, 4))
    for mesher in MESHERS:
        pts = sorted((r["seconds"], r["rmse"]) for r in rows if r["mesher"] == mesher and r.get("triangles"))
        if pts:
            ax.plot(*zip(*pts, strict=True), marker="o", label=mesher)
    ref = rows[0]
    ax.axvline(ref["seconds"], color="grey", ls="--", label="reference (grid) solver time")
    ax.set_xscale("log")
    ax.set_xlabel("ANUGA solver wall time (s)")
    ax.set_ylabel("final depth RMSE vs the grid (m)")
    ax.set_title(f"{label}: rain-on-grid, {ref['triangles']:,} reference triangles", fontsize=9)
    ax.legend(fontsize=8)
    fig.tight_layout()
    IMG.mkdir(parents=True, exist_ok=True)
    path = IMG / f"flood_{name}.png"
    fig.savefig(path, dpi=80)
    plt.close(fig)
    return path


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--dems", nargs="+", default=["bijou", "helens"], choices=sorted(DEMS))
    ap.add_argument("--rain-mm-h", type=float, default=100.0)
    ap.add_argument("--minutes", type=float, default=15.0, help="minutes of rain")
    ap.add_argument("--drain-minutes", type=float, default=5.0, help="minutes without rain after it")
    ap.add_argument("--manning", type=float, default=0.03)
    ap.add_argument("--sizes", type=float, nargs="+", default=[0.02, 0.05, 0.1],
                    help="triangle counts as shares of the reference's")
    ap.add_argument("--meshers", nargs="+", default=list(MESHERS), choices=MESHERS)
    ap.add_argument("--boundary", default="Transmissive_stage_zero_momentum_boundary",
                    help="the ANUGA boundary class on every border edge")
    ap.add_argument("--yieldstep", type=float, default=30.0, help="seconds between hydrograph samples")
    ap.add_argument("--coarsen", nargs="*", default=[], metavar="DEM=FACTOR",
                    help="block-mean a DEM first, e.g. helens=2")
    ap.add_argument("--out", default=str(HERE / "RESULTS_flood.md"))
    args = ap.parse_args(argv)
    args.coarsen = {k: int(v) for k, v in (s.split("=") for s in args.coarsen)}
    command = "python benchmarks/flood_solver.py " + " ".join(argv if argv is not None else sys.argv[1:])
    lines = ["# Meshes judged by a flood solver (ANUGA rain-on-grid)", "",
             f"Command: `{command.strip()}`  ", f"{machine()}, ANUGA {anuga.__version__}.", "",
             f"Event: uniform rain {args.rain_mm_h:g} mm/h for {args.minutes:g} min, then {args.drain_minutes:g} min "
             f"without rain; Manning's n {args.manning:g}; `anuga.{args.boundary}` on every border edge; dry start. "
             "The reference is the full-resolution grid mesh. flood: its defaults (streams derived from the DEM, "
             "expected depth estimated, time step auto), only max_error chosen for each count (at most 8 tries, "
             "the nearest kept: the count it reached is in the table). "
             "Depth RMSE and IoU (depth > 5 cm) at the reference's "
             "triangle centroids, each run's centroid depths interpolated linearly there. Outflow: rain added "
             f"minus the change of stored water, per {args.yieldstep:g} s yieldstep; NSE against the reference's. "
             "Max error: the mesh against the DEM at every valid cell. Solver s: wall time of `evolve`; mesh s: "
             "making the mesh and its domain. ANUGA's meshes: Triangle over the outline of the reference (collinear "
             "points dropped), maximum triangle area chosen for flood's count at each size, heights interpolated "
             "linearly from the reference mesh at their vertices. Below each table: flood against ANUGA's mesh at "
             "the same count, and against ANUGA's curve at equal solver time (interpolated in log time).", ""]
    out = Path(args.out)
    for name in args.dems:
        label, rows = bench(name, args)
        lines += table(label, rows)
        png = picture(name, label, rows)
        lines += [f"![depth RMSE against solver time]({Path('..') / png.relative_to(ROOT)})", ""]
        out.write_text("\n".join(lines))  # after every DEM: what is measured is kept
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
