"""Greedy insertion on thin strips and long corridors: tinsmith against pydelatin, side by side in one run.

    pip install -e ".[test]" pydelatin scipy
    python benchmarks/strips_vs_peers.py                 # writes benchmarks/RESULTS_strips.md
    python benchmarks/strips_vs_peers.py --repeat 3 --only noise

A sibling of ``greedy_vs_peers.py``, whose child process, timing and judging
it reuses: each tool runs in a fresh process per repetition (median of
``--repeat``, the tools taking turns), after meshing the same 600 x 600
warm-up grid; time covers the call only (array in, mesh out); both meshes are
judged by tinsmith's metrics.  max_error is 1/1000 of each raster's height
range (tinsmith's default rule).

Rasters (float32, cell size 1):

- ``2 x N Big Tujunga``: the Big Tujunga SRTM DEM (30 m, 643 x 1197) read as a
  serpentine of 2-row bands (rows 0-1 west to east, rows 2-3 east to west,
  ...), the bands joined end to end: real terrain, continuous but at the turns;
  N = 25,000 to 200,000 (the DEM holds 2 x 384,111).
- ``2 x N noise``: independent N(0, 1) heights, the hardest case for greedy
  insertion on a strip (almost every cell becomes a vertex).
- ``2 x N smooth``: a sine of period 314 cells and amplitude 10, the second row
  0.3 higher: greedy insertion peels one period off a strip-long triangle at
  each step and rescans the rest, so both tools grow about 4x per doubling.
- ``N x 2``: the first three of Big Tujunga and noise, transposed (a strip standing up).
- ``20 x N Big Tujunga``: the same serpentine with 20-row bands (up to 20 x 38,304).
- ``corridor``: no shared DEM spans 50 km (the longest, Big Tujunga, is 35.9 km
  east-west, 40.8 km corner to corner), so the corridor follows a path of
  50 km inside it: a meander west to east, three sine periods about the
  middle row, the amplitude (75 cells) set so that the arc is 50.0 km.  ``in
  place``: the whole 643 x 1197 grid with nodata outside the cells whose
  centre lies within 30 m of a point of the path (4,423 cells, 1 to 6 a
  column, about 80 m across on average; a strict 50 m corridor of a 30 m grid
  would be 1 or 2 cells, too narrow for triangles in places); tinsmith only,
  pydelatin cannot skip nodata.  ``straightened``: the path sampled every
  30 m, the nearest cells at -30, 0 and +30 m across it, as a 3 x 1,667
  raster that both tools mesh.  At 30 m a 50 km corridor is a small raster:
  the long strips above are the stress test.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
from _common import HERE, SHARED, machine
from greedy_vs_peers import judge, measure

TUJUNGA = SHARED / "data/terrain/big_tujunga_canyon/srtm_bigtujunga30m_utm11.tif"
CELL = 30.0  # m, Big Tujunga's cell
CORRIDOR_KM = 50.0
CORRIDOR_HALF_WIDTH = 30.0  # m from the centreline


def tujunga() -> np.ndarray:
    import rasterio

    with rasterio.open(TUJUNGA) as ds:
        return ds.read(1).astype(np.float32)


def serpentine(z: np.ndarray, rows: int, n: int) -> np.ndarray:
    """(rows, n): the DEM's bands of ``rows`` rows, every other one reversed, joined end to end."""
    bands = [z[k:k + rows] if (k // rows) % 2 == 0 else z[k:k + rows, ::-1] for k in range(0, z.shape[0] - rows + 1, rows)]
    strip = np.concatenate(bands, axis=1)
    if n > strip.shape[1]:
        raise ValueError(f"the DEM holds {rows} x {strip.shape[1]}, not {rows} x {n}")
    return np.ascontiguousarray(strip[:, :n])


def corridor_path(shape) -> tuple[np.ndarray, np.ndarray]:
    """(x, y) in cells of a 50 km meander west to east (three sine periods about the middle row), every cell length."""
    h, w = shape
    margin = 8
    length_cells = CORRIDOR_KM * 1000 / CELL
    span = w - 1 - 2 * margin
    t = np.linspace(0, 1, 20001)
    lo, hi = 0.0, h / 2 - margin
    for _ in range(60):  # the amplitude whose arc length is 50 km, by bisection
        amp = (lo + hi) / 2
        arc = np.hypot(np.diff(span * t), np.diff(amp * np.sin(6 * np.pi * t))).sum()
        lo, hi = (amp, hi) if arc < length_cells else (lo, amp)
    xs, ys = margin + span * t, (h - 1) / 2 + amp * np.sin(6 * np.pi * t)
    s = np.concatenate([[0.0], np.cumsum(np.hypot(np.diff(xs), np.diff(ys)))])
    at = np.arange(0.0, s[-1], 1.0)
    return np.interp(at, s, xs), np.interp(at, s, ys)


def corridor(z: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """(in-place heights, nodata mask, straightened 3 x L strip, path length in km)."""
    from scipy import ndimage

    x, y = corridor_path(z.shape)
    h, w = z.shape
    near = np.ones((h, w), bool)
    near[np.clip(np.rint(y).astype(int), 0, h - 1), np.clip(np.rint(x).astype(int), 0, w - 1)] = False
    dist = ndimage.distance_transform_edt(near)  # cells to the nearest path sample
    mask = dist * CELL > CORRIDOR_HALF_WIDTH
    # straightened: the cells at -1, 0, +1 cell across the path (normal to it), nearest cell
    dx, dy = np.gradient(x), np.gradient(y)
    norm = np.hypot(dx, dy)
    nx, ny = -dy / norm, dx / norm
    strip = np.stack([z[np.clip(np.rint(y + k * ny).astype(int), 0, h - 1), np.clip(np.rint(x + k * nx).astype(int), 0, w - 1)]
                      for k in (-1, 0, 1)])
    km = float(np.hypot(np.diff(x), np.diff(y)).sum() * CELL / 1000)
    return z, mask, np.ascontiguousarray(strip.astype(np.float32)), km


def cases(only: str | None):
    z = tujunga()
    out = []
    for n in (25_000, 50_000, 100_000, 200_000):
        out.append((f"2 x {n:,} Big Tujunga", serpentine(z, 2, n), None))
    rng = np.random.default_rng(0)
    for n in (25_000, 50_000, 100_000, 200_000):
        out.append((f"2 x {n:,} noise", rng.normal(size=(2, n)).astype(np.float32), None))
    for n in (25_000, 50_000, 100_000, 200_000):  # a period of 314 cells: greedy peels one off at a time
        x = np.arange(n)
        out.append((f"2 x {n:,} smooth", np.vstack([np.sin(x / 50) * 10, np.sin(x / 50) * 10 + 0.3]).astype(np.float32),
                    None))
    for n in (25_000, 50_000, 100_000):  # the same strips standing up (rows of 2 cells)
        out.append((f"{n:,} x 2 Big Tujunga", np.ascontiguousarray(serpentine(z, 2, n).T), None))
        out.append((f"{n:,} x 2 noise", np.ascontiguousarray(out[4 + [25_000, 50_000, 100_000].index(n)][1].T), None))
    for n in (5_000, 10_000, 20_000, 38_000):
        out.append((f"20 x {n:,} Big Tujunga", serpentine(z, 20, n), None))
    zc, mask, strip, km = corridor(z)
    out.append((f"corridor {km:.1f} km straightened 3 x {strip.shape[1]:,}", strip, None))
    out.append((f"corridor {km:.1f} km in place 643 x 1197, {int((~mask).sum()):,} cells hold data", zc, mask))
    return [c for c in out if only is None or only in c[0]]


def main() -> None:
    import tempfile

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--only", help="run only the rasters whose name contains this text")
    ap.add_argument("--out", default=str(HERE / "RESULTS_strips.md"))
    ap.add_argument("--workdir", default=str(HERE / ".cache"))
    args = ap.parse_args()
    workdir = Path(args.workdir)
    workdir.mkdir(exist_ok=True)
    rows = []
    with tempfile.TemporaryDirectory(dir=workdir) as tmp:
        tmp = Path(tmp)
        for name, z, mask in cases(args.only):
            valid = z if mask is None else z[~mask]
            max_error = float(f"{(float(valid.max()) - float(valid.min())) / 1000:.4g}")
            if mask is None:
                res = measure(("tinsmith", "pydelatin"), z, max_error, args.repeat, tmp)
                ts, pd = res["tinsmith"], res["pydelatin"]
                tj = judge(z, ts["vertices"], ts["triangles"], "tinsmith")
                pj = judge(z, pd["vertices"], pd["triangles"], "pydelatin")
            else:
                ts = measure(("tinsmith",), z, max_error, args.repeat, tmp, nodata_mask=mask)["tinsmith"]
                tj = judge(np.where(mask, np.nan, z), ts["vertices"], ts["triangles"], "tinsmith", nodata_mask=mask)
                pd = pj = None
            ratio = f"{ts['time'] / pd['time']:.2f}" if pd else "-"
            print(name, max_error, f"tinsmith {ts['time']:.3f}s", f"pydelatin {pd['time']:.3f}s" if pd else "", ratio, tj, pj,
                  flush=True)
            rows.append((name, z.shape, max_error, ts, tj, pd, pj))
    write_table(rows, args)


def write_table(rows, args) -> None:
    lines = [
        "# Greedy insertion on thin strips and corridors: tinsmith vs pydelatin",
        "",
        f"Command: `python benchmarks/strips_vs_peers.py --repeat {args.repeat}`  ",
        f"{machine()}; median of {args.repeat} runs, each in a fresh process, the tools taking turns "
        "(the child process of `greedy_vs_peers.py`: both tools warmed up on the same 600 x 600 grid first; "
        "time covers the call only). max_error: 1/1000 of the height range. Errors: tinsmith's metrics against "
        "every valid cell. Rasters: see the script's docstring.",
        "",
        "| raster | max_error | tinsmith s | pydelatin s | time ratio | tinsmith s per 1M cells | tinsmith triangles "
        "| pydelatin triangles | tinsmith max / RMS | pydelatin max / RMS |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for name, shape, max_error, ts, tj, pd, pj in rows:
        cells = shape[0] * shape[1]
        lines.append(
            f"| {name} | {max_error:g} | {ts['time']:.3f} | {pd['time']:.3f} | {ts['time'] / pd['time']:.2f} "
            f"| {ts['time'] / cells * 1e6:.2f} | {tj[1]:,} | {pj[1]:,} | {tj[2]:.3f} / {tj[3]:.3f} "
            f"| {pj[2]:.3f} / {pj[3]:.3f} |"
            if pd else
            f"| {name} | {max_error:g} | {ts['time']:.3f} | - | - | - | {tj[1]:,} | - | {tj[2]:.3f} / {tj[3]:.3f} | - |"
        )
    Path(args.out).write_text("\n".join(lines) + "\n")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
