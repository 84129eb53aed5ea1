"""Point-cloud reconstruction (Gopi and Krishnan 2002): tinsmith against scipy's 2.5-D Delaunay.

Time, peak memory and mesh checks.

    pip install -e ".[test]"
    python benchmarks/reconstruct_bench.py       # writes benchmarks/RESULTS_reconstruct.md

Every run is a fresh subprocess, so its peak resident memory (``ru_maxrss``)
is its own; the clock and the memory of the call (resident set sampled by a
thread) cover the meshing call only (the cloud is read or made before it,
and the kernels are loaded by a warm-up run on a tiny cloud).

* Heightfield mode on the LAZ files (and the Delft cloud), against
  ``scipy.spatial.Delaunay`` of the x-y positions of the same cloud, and of
  the representatives tinsmith keeps (one per dexel).
* General mode on evenly sampled closed surfaces (a torus by a jittered grid
  of its angles, a sphere by the Fibonacci lattice; 10k, 100k, 1M points)
  and on the LAZ files.
* The fold at sharp edges: the share of each mesh's area whose triangles face
  down (normal with a negative z, after each component is turned outwards or
  upwards), on the LiDAR files and on a box scene (a 20 m box, 10 m high, on
  80 x 80 m of flat ground: 20,000 random ground and roof points and 800 on its
  walls).
* Forest clouds: general against heightfield mode on the lidR tiles and on a
  synthetic forest tile (``make_large_cloud.py --points 0.85e6 --files 1x1
  --seed 1 --forest-cover 0.9``, made in a temporary folder), and general
  mode on the points heightfield mode keeps (one per dexel).
  ``--only-forest`` (and ``--only-view`` for the folds) reruns that section
  alone and puts it in place.
* Memory against size: the torus at four sizes.

Each mesh is checked: edges of more than two triangles, edges walked twice
the same way, pairs of triangles that cut each other, border loops;
"vertices" counts the points the triangles use.  Open3D's ball pivoting,
the issue's peer for general mode, is in the table when ``import open3d``
works (``pip install open3d``; its wheel needs Debian's ``libusb-1.0-0``).
"""

from __future__ import annotations

import argparse
import hashlib
import json
import resource
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
from _common import HERE, SHARED, machine

LAZ = {
    "lidR Topography": SHARED / "data/terrain/lidR_forest_lakes/Topography.laz",
    "lidR MixedConifer": SHARED / "data/terrain/lidR_forest_lakes/MixedConifer.laz",
    "CODEM (NCALM)": SHARED / "data/urban/codem_ncalm/codem_pc.laz",
    "Delft AHN3 merged": SHARED / "data/urban/delft_ahn3/delft_ahn3_merged.laz",
}


def _cloud(source: str):
    import tinsmith
    from tinsmith import shapes

    kind, _, arg = source.partition(":")
    if kind == "box":
        return tinsmith.PointCloud(shapes.box_scene())
    if kind == "classes":  # ground and buildings
        return tinsmith.read(arg, classes=[2, 6])
    if kind == "torus":
        return tinsmith.PointCloud(shapes.torus_points(int(arg)))
    if kind == "sphere":
        return tinsmith.PointCloud(shapes.sphere_points(int(arg), 5.0))
    return tinsmith.read(arg)


def _checks(vertices, triangles) -> dict:
    import tinsmith
    from tinsmith import metrics

    mesh = tinsmith.TerrainMesh(np.asarray(vertices, float), np.asarray(triangles, np.int64))
    problems = metrics.surface_problems(mesh)
    loops = metrics.border_loops(mesh.triangles, mesh.n_vertices)
    v, t = mesh.vertices, mesh.triangles
    normal = np.cross(v[t[:, 1]] - v[t[:, 0]], v[t[:, 2]] - v[t[:, 0]])
    area = np.linalg.norm(normal, axis=1)
    steep_down = normal[:, 2] < -0.3 * area  # facing more than 17 degrees below the horizon
    return {"down_pct": float(100 * area[normal[:, 2] < 0].sum() / max(area.sum(), 1e-300)),
            "down30_pct": float(100 * area[steep_down].sum() / max(area.sum(), 1e-300)),
            "vertices": int(len(np.unique(mesh.triangles))), "triangles": mesh.n_triangles,
            "nonmanifold": problems["overused"], "misoriented": problems["misoriented"],
            "intersections": metrics.self_intersections(mesh),
            "border_loops": loops}


class _RssPeak:
    """The largest resident set size above the one at the start, sampled every millisecond by a thread while the
    block runs (the kernels release the interpreter lock): the memory the call itself needed."""

    def __enter__(self):
        import threading

        self.start = self.peak = self._rss()
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._poll, daemon=True)
        self._thread.start()
        return self

    def __exit__(self, *exc):
        self._stop.set()
        self._thread.join()
        self.peak = max(self.peak, self._rss())
        self.mb = (self.peak - self.start) / 1048576.0

    @staticmethod
    def _rss() -> int:
        with open("/proc/self/statm") as f:
            return int(f.read().split()[1]) * resource.getpagesize()

    def _poll(self):
        while not self._stop.wait(0.001):
            self.peak = max(self.peak, self._rss())


def _mesh(tool: str, cloud, mode: str | None, view: str = "any", workers: int | None = None):
    """(vertices, triangles) of one tool's mesh of the cloud."""
    from tinsmith.algorithms.reconstruct.reconstruct import reconstruct

    if tool == "tinsmith":
        mesh = reconstruct(cloud, mode=mode, view=view, workers=workers)
        return mesh.vertices, mesh.triangles
    if tool == "scipy":
        from scipy.spatial import Delaunay

        return cloud.xyz, Delaunay(cloud.xyz[:, :2]).simplices
    if tool == "open3d":
        import open3d as o3d

        pcd = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(cloud.xyz - cloud.xyz.mean(axis=0)))
        pcd.estimate_normals()
        d = float(np.mean(pcd.compute_nearest_neighbor_distance()))
        m = o3d.geometry.TriangleMesh.create_from_point_cloud_ball_pivoting(
            pcd, o3d.utility.DoubleVector([1.5 * d, 3 * d]))
        return np.asarray(m.vertices), np.asarray(m.triangles)
    raise ValueError(tool)


def worker(spec: dict) -> dict:
    """One run in this process: the tool, the cloud, the clock and the memory of the call, the checks."""
    import tinsmith
    from tinsmith import shapes
    from tinsmith.algorithms.reconstruct.reconstruct import reconstruct

    reconstruct(shapes.torus_points(400), mode=spec.get("mode", "general"))  # kernels loaded
    cloud = _cloud(spec["source"])
    if spec.get("order"):  # the same points in another order
        cloud = tinsmith.PointCloud(cloud.xyz[np.random.default_rng(spec["order"]).permutation(len(cloud))])
    if spec.get("one_strip"):  # the whole cloud in one front, as before strips
        from tinsmith.algorithms.reconstruct import projection

        projection.STRIP_POINTS = len(cloud) + 1
    tool = spec["tool"]
    if tool.endswith("-kept"):  # scipy, or general mode, on the points tinsmith's heightfield mode keeps
        cloud, tool = tinsmith.PointCloud(reconstruct(cloud, mode="heightfield").vertices), tool[: -len("-kept")]
    with _RssPeak() as call:
        start = time.perf_counter()
        vertices, triangles = _mesh(tool, cloud, spec.get("mode"), spec.get("view", "any"), spec.get("workers"))
        seconds = time.perf_counter() - start
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
    digest = hashlib.sha256(np.ascontiguousarray(triangles, np.int64).tobytes()).hexdigest()[:12]
    if spec.get("checks", True):
        checks = _checks(vertices, triangles)
    else:  # the border loops alone (the self-intersection test is the slow one)
        from tinsmith import metrics

        checks = {"border_loops": metrics.border_loops(np.asarray(triangles, np.int64), len(vertices))}
    return {**spec, "points": len(cloud), "time": seconds, "call_mb": call.mb, "peak_mb": peak, "triangles_sha": digest,
            **checks}


def run(spec: dict, timeout: float) -> dict:
    try:
        proc = subprocess.run([sys.executable, __file__, "--worker", json.dumps(spec)], capture_output=True,
                              text=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        return {**spec, "error": f"over {timeout:.0f} s"}
    if proc.returncode != 0:
        return {**spec, "error": proc.stderr.strip().splitlines()[-1][:120]}
    out = json.loads(proc.stdout.strip().splitlines()[-1])
    print({k: (round(v, 3) if isinstance(v, float) else v) for k, v in out.items()}, flush=True)
    return out


def table(rows) -> list[str]:
    lines = ["| cloud | tool | mode | points | time | memory of the call | peak memory | vertices | triangles | "
             "non-manifold edges | misoriented edges | self-intersections | border loops | area facing down |",
             "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
    for r in rows:
        if "error" in r:
            lines.append(f"| {r['label']} | {r['tool']} | {r.get('mode', '')} | | {r['error']} | | | | | | | | | |")
            continue
        lines.append(
            f"| {r['label']} | {r['tool']} | {r.get('mode', '')} | {r['points']:,} | {r['time']:.2f} s | "
            f"{r['call_mb']:.0f} MB | {r['peak_mb']:.0f} MB | {r['vertices']:,} | {r['triangles']:,} | "
            f"{r['nonmanifold']} | {r['misoriented']} | {r['intersections']} | {r['border_loops']} | "
            f"{r['down_pct']:.1f}% |"
        )
    return lines


def view_section(timeout: float) -> list[str]:
    """General mode with view="any" (the paper's rules) and view="above" (no face turned down) on airborne clouds."""
    clouds = {"box scene": "box:", "Delft AHN3, ground and buildings": f"classes:{LAZ['Delft AHN3 merged']}",
              **{label: f"file:{LAZ[label]}" for label in ("Delft AHN3 merged", "CODEM (NCALM)", "lidR Topography",
                                                            "lidR MixedConifer")}}
    lines = ["", "## Folds: view=\"above\" for airborne clouds", "",
             "General mode with the paper's rules (`view=\"any\"`, the default) and with `view=\"above\"` (an "
             "airborne scan saw every surface from above: a triangle facing more than 17 degrees below the horizon "
             "is not made), same run. Facing down: the share of the area whose normal has a negative z; steeply "
             "down: more than 17 degrees below the horizon (z of the unit normal below -0.3).", "",
             "| cloud | view | points | time | vertices | border loops | facing down | steeply down | "
             "non-manifold edges | misoriented edges | self-intersections |", "| --- " * 11 + "|"]
    for label, source in clouds.items():
        for view in ("any", "above"):
            r = run({"label": label, "tool": "tinsmith", "mode": "general", "view": view, "source": source}, timeout)
            if "error" in r:
                lines.append(f"| {label} | {view} | | {r['error']} |" + " |" * 7)
                continue
            lines.append(f"| {label} | {view} | {r['points']:,} | {r['time']:.2f} s | {r['vertices']:,} | "
                         f"{r['border_loops']:,} | {r['down_pct']:.1f}% | {r['down30_pct']:.1f}% | {r['nonmanifold']} | "
                         f"{r['misoriented']} | {r['intersections']} |")
    return lines


def forest_section(timeout: float) -> list[str]:
    """General against heightfield mode on the forest tiles (each mode in its own process)."""
    import tempfile

    tiles = {k: v for k, v in LAZ.items() if k.startswith("lidR") and v.exists()}
    folder = tempfile.mkdtemp()
    subprocess.run([sys.executable, str(HERE / "make_large_cloud.py"), folder, "--points", "0.85e6", "--files", "1x1",
                    "--seed", "1", "--forest-cover", "0.9"], check=True, capture_output=True)
    tiles["synthetic forest (make_large_cloud, 0.85e6, cover 0.9)"] = Path(folder) / "cloud_00_00.laz"
    lines = ["", "## Forest clouds: general against heightfield mode", "",
             ("General mode on the whole cloud, and on the points heightfield mode keeps (one per dexel: the same "
              "number of points as heightfield mode joins, a single layer), each in its own process."), "",
             ("| cloud | points | general | heightfield | ratio | points kept by heightfield | general on the kept "
              "points | ratio | border loops (general) |"), "| --- " * 9 + "|"]
    for label, path in tiles.items():
        gen, hf, kept = (run({"label": label, "tool": tool, "mode": mode, "source": f"file:{path}"}, timeout)
                         for tool, mode in (("tinsmith", "general"), ("tinsmith", "heightfield"),
                                            ("tinsmith-kept", "general")))
        if "error" in gen or "error" in hf or "error" in kept:
            lines.append(f"| {label} | | {gen.get('error', '')} | {hf.get('error', '')} | | | {kept.get('error', '')} |"
                         " | |")
            continue
        lines.append(f"| {label} | {gen['points']:,} | {gen['time']:.2f} s | {hf['time']:.2f} s | "
                     f"{gen['time'] / hf['time']:.1f}x | {hf['vertices']:,} | {kept['time']:.2f} s | "
                     f"{kept['time'] / hf['time']:.1f}x | {gen['border_loops']:,} |")
    return lines


STRIP_ORDERS = 5
"""Border loops are compared over the file's order and this many less one shuffles of it: a front's loops move
with the order it meets the points in (CODEM in one piece: 498 to 553 over four orders)."""


def strips_section(timeout: float, runs: int) -> list[str]:
    """General mode in strips on threads against the whole cloud in one front: time on one and two workers (the
    median of ``runs`` fresh processes), the same triangles on both, and border loops over several point orders."""
    clouds = {"torus 1,000,000": "torus:1000000", **{label: f"file:{LAZ[label]}" for label in
                                                      ("CODEM (NCALM)", "Delft AHN3 merged") if LAZ[label].exists()}}
    lines = ["", "## Strips on threads", "",
             "General mode meshes a cloud of 200,000 points or more in strips of dexel columns (one per 100,000 "
             "points, at most 8), on `workers` threads, then joins them; *one front* is the whole cloud in one piece "
             f"(as before strips, on one core). Time: the median of {runs} fresh processes. Border loops: the mean over "
             f"the file's order and {STRIP_ORDERS - 1} shuffles (range in brackets; the closed torus in its own order "
             "alone), for one front and for the strips.",
             "", "| cloud | view | points | strips | one front | strips, 1 worker | strips, 2 workers | "
             "2 workers / one front | same triangles on 1 and 2 workers | border loops, one front | "
             "border loops, strips | non-manifold, misoriented, self-intersections (strips) |", "| --- " * 12 + "|"]
    for label, source in clouds.items():
        orders = 1 if label.startswith("torus") else STRIP_ORDERS  # closed in any order
        for view in ("any", "above"):
            base = {"label": label, "tool": "tinsmith", "mode": "general", "view": view, "source": source}
            times, found = {}, {}
            for key, extra in (("one", {"one_strip": True, "workers": 1}), ("w1", {"workers": 1}),
                               ("w2", {"workers": 2})):
                got = [run({**base, **extra, "checks": i == 0}, timeout) for i in range(runs)]
                bad = next((r for r in got if "error" in r), None)
                if bad:
                    lines.append(f"| {label} | {view} | | | {bad['error']} |" + " |" * 7)
                    break
                times[key], found[key] = float(np.median([r["time"] for r in got])), got[0]
            else:
                loops = {key: [found[key]["border_loops"]] + [
                    run({**base, **extra, "order": k, "checks": False}, timeout).get("border_loops", -1)
                    for k in range(1, orders)]
                    for key, extra in (("one", {"one_strip": True, "workers": 1}), ("w2", {"workers": 2}))}
                same = "yes" if found["w1"]["triangles_sha"] == found["w2"]["triangles_sha"] else "**no**"
                r = found["w2"]
                lines.append(
                    f"| {label} | {view} | {r['points']:,} | {_strips_of(r['points'])} | {times['one']:.2f} s | "
                    f"{times['w1']:.2f} s | {times['w2']:.2f} s | {times['w2'] / times['one']:.2f}x | {same} | "
                    + " | ".join(f"{np.mean(v):,.0f} ({min(v):,}-{max(v):,})" for v in loops.values())
                    + f" | {r['nonmanifold']}, {r['misoriented']}, {r['intersections']} |")
    return lines


def _strips_of(points: int) -> int:
    from tinsmith.algorithms.reconstruct.projection import MAX_STRIPS, STRIP_POINTS

    return max(1, min(MAX_STRIPS, points // STRIP_POINTS))


def replace_section(out: str, heading: str, section: list[str], command: str) -> None:
    """Put ``section`` (its heading at ``section[1]``) in place of the section of ``out`` whose heading starts
    with ``heading`` (at the end when there is none), noting the command that reran it alone."""
    note = f"This section alone: `{command}`; {machine()}."
    section = section[:2] + ["", note] + section[2:]
    text = Path(out).read_text().rstrip("\n").split("\n")
    start = next((i for i, line in enumerate(text) if line.startswith(heading)), len(text))
    end = next((i for i in range(start + 1, len(text)) if text[i].startswith("## ")), len(text))
    text = text[:start - (1 if start < len(text) else 0)] + section + ([""] if end < len(text) else []) + text[end:]
    Path(out).write_text("\n".join(text) + "\n")
    print(f"wrote the section {heading!r} of {out}")


def open3d_peer() -> tuple[list[str], str]:
    """(["open3d"] when Open3D imports here, else []; the sentence the report says about it)."""
    try:
        import open3d  # noqa: F401

        return ["open3d"], "Open3D ball pivoting (radii 1.5 and 3 times the mean spacing) runs beside general mode."
    except Exception as exc:  # noqa: BLE001 - any import failure means the peer cannot run here
        return [], f"Open3D could not run on this machine (`import open3d`: {type(exc).__name__}: {exc})."


def heightfield_section(timeout: float) -> list[str]:
    """Heightfield mode against scipy's 2.5-D Delaunay on the whole cloud and on the points tinsmith keeps."""
    lines = ["## Heightfield mode against scipy's 2.5-D Delaunay", ""]
    hf_rows = []
    for label, path in LAZ.items():
        if not path.exists():
            continue
        for tool in ("tinsmith", "scipy", "scipy-kept"):
            hf_rows.append(run({"label": label, "tool": tool, "mode": "heightfield", "source": f"file:{path}"},
                               timeout))
    lines += table(hf_rows) + [""]
    for label in LAZ:
        mine = next((r for r in hf_rows if r["label"] == label and r["tool"] == "tinsmith" and "error" not in r), None)
        full = next((r for r in hf_rows if r["label"] == label and r["tool"] == "scipy" and "error" not in r), None)
        kept = next((r for r in hf_rows if r["label"] == label and r["tool"] == "scipy-kept" and "error" not in r), None)
        if mine and full and kept:
            lines.append(f"- {label}: scipy on the whole cloud takes {full['time'] / mine['time']:.1f}x tinsmith's "
                         f"time, on the {mine['vertices']:,} kept points {kept['time'] / mine['time']:.1f}x.")
    return lines


def general_section(timeout: float, peers: list[str]) -> list[str]:
    """General mode on synthetic shapes, a box scene and the surveys, beside the peers."""
    rows = []
    lines = ["", "## General mode", ""]
    for n in (10_000, 100_000, 1_000_000):
        for shape in ("torus", "sphere"):
            rows.append(run({"label": f"{shape} {n:,}", "tool": "tinsmith", "mode": "general",
                             "source": f"{shape}:{n}"}, timeout))
            for peer in peers:
                rows.append(run({"label": f"{shape} {n:,}", "tool": peer, "source": f"{shape}:{n}"}, timeout))
    rows.append(run({"label": "box scene", "tool": "tinsmith", "mode": "general", "source": "box:"}, timeout))
    delft_city = LAZ["Delft AHN3 merged"]
    if delft_city.exists():
        rows.append(run({"label": "Delft AHN3, ground and buildings", "tool": "tinsmith", "mode": "general",
                         "source": f"classes:{delft_city}"}, timeout))
    for label, path in LAZ.items():
        if path.exists():
            rows.append(run({"label": label, "tool": "tinsmith", "mode": "general", "source": f"file:{path}"},
                            timeout))
            for peer in peers:
                rows.append(run({"label": label, "tool": peer, "source": f"file:{path}"}, timeout))
    lines += table(rows) + [""]
    for label in dict.fromkeys(r["label"] for r in rows):
        mine = next((r for r in rows if r["label"] == label and r["tool"] == "tinsmith" and "error" not in r), None)
        for peer in peers:
            other = next((r for r in rows if r["label"] == label and r["tool"] == peer), None)
            if mine and other and "error" not in other:
                lines.append(f"- {label}: {peer} takes {other['time'] / mine['time']:.1f}x tinsmith's time; "
                             f"{other['misoriented']} misoriented edges and {other['border_loops']:,} border loops "
                             f"against {mine['misoriented']} and {mine['border_loops']:,}.")
            elif mine and other:
                lines.append(f"- {label}: {peer} {other['error']}; tinsmith {mine['time']:.2f} s.")
    return lines


def memory_section(timeout: float) -> list[str]:
    """The memory of the call against the size of a torus in general mode."""
    mem = [run({"label": f"torus {n:,}", "tool": "tinsmith", "mode": "general", "source": f"torus:{n}"}, timeout)
           for n in (30_000, 100_000, 300_000, 1_000_000)]
    lines = ["", "## Memory against size (general mode, torus)", "",
             "The memory of the call: the largest resident set above the one at its start (the cloud is made before).",
             "", "| points | memory of the call | per point | time |", "| --- | --- | --- | --- |"]
    for r in mem:
        if "error" not in r:
            per_point = 1048576 * r["call_mb"] / r["points"]
            lines.append(f"| {r['points']:,} | {r['call_mb']:.1f} MB | {per_point:.0f} bytes "
                         f"| {r['time']:.2f} s |")
    return lines


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--worker")
    ap.add_argument("--timeout", type=float, default=120.0)
    ap.add_argument("--out", default=str(HERE / "RESULTS_reconstruct.md"))
    ap.add_argument("--only-view", action="store_true",
                    help="run the folds section (view any / above) alone and put it in place in --out")
    ap.add_argument("--only-forest", action="store_true",
                    help="run the forest section (general against heightfield mode) alone and put it in place in --out")
    ap.add_argument("--only-strips", action="store_true",
                    help="run the strips section (threads against one front) alone and put it in place in --out")
    ap.add_argument("--runs", type=int, default=3, help="fresh processes timed per configuration (strips section)")
    args = ap.parse_args()
    if args.worker:
        print(json.dumps(worker(json.loads(args.worker))))
        return
    if args.only_view:
        replace_section(args.out, "## Folds", view_section(args.timeout),
                        "python benchmarks/reconstruct_bench.py --only-view")
        return
    if args.only_forest:
        replace_section(args.out, "## Forest", forest_section(args.timeout),
                        "python benchmarks/reconstruct_bench.py --only-forest")
        return
    if args.only_strips:
        replace_section(args.out, "## Strips", strips_section(args.timeout, args.runs),
                        f"python benchmarks/reconstruct_bench.py --only-strips --runs {args.runs}")
        return
    peers, o3d_note = open3d_peer()
    lines = ["# Point-cloud reconstruction (Gopi and Krishnan 2002)", "",
             "Command: `python benchmarks/reconstruct_bench.py`  ",
             f"{machine()}. Time of the meshing call alone; the memory of the call is the largest resident set above "
             "the one at its start (sampled every millisecond), the peak memory that of the whole run (a fresh "
             "process each, kernels loaded). " + o3d_note, ""]
    lines += heightfield_section(args.timeout)
    lines += general_section(args.timeout, peers)
    lines += forest_section(args.timeout)
    lines += view_section(args.timeout)
    lines += strips_section(args.timeout, args.runs)
    lines += memory_section(args.timeout)
    Path(args.out).write_text("\n".join(lines) + "\n")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
