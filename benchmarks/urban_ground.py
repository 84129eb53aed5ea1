"""The ground without a DTM: tinsmith.ground (a progressive morphological filter) against the grey-scale opening before it.

    python benchmarks/urban_ground.py            # prints the tables (Markdown); --out FILE writes them too

1. Bare terrain, no building on it: the share of the area ``tinsmith.city``
   takes as buildings with no ground given, on St. Helens (30 m), Big
   Tujunga (30 m SRTM), the West Bijou gully (3 m) and two synthetic
   hillsides of 1 m cells (sines of 5 m over 120 m and 190 m; alone, 17
   degrees at the steepest, and on a tilt to 30 degrees).
2. Cities, as ``benchmarks/urban_cities.py`` runs them (defaults): the
   buildings found, and on Delft the union IoU, precision and recall
   against the 160 BGT outlines.  Runs whose ground comes from the cloud's
   classes (Delft's and Autzen's LAZ) do not use either estimate and are
   left out.
3. The ground against Delft's DTM (the TIN of its ground points): RMSE,
   95th percentile of the absolute difference, and bias, over every cell,
   over the cells where the DSM is within 0.3 m of the DTM (the ground is
   seen) and over the others (the ground under objects); from the DSM, and
   from the LAZ itself (``tinsmith.ground`` of the cloud, its lowest point
   a cell).
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np
from _common import SHARED, machine

DATA = SHARED / "data"
BARE = {
    "St. Helens 30 m": "terrain/st_helens/SainteHelens_30m.tif",
    "Big Tujunga 30 m": "terrain/big_tujunga_canyon/srtm_bigtujunga30m_utm11.tif",
    "West Bijou gully 3 m": "terrain/landlab_west_bijou/west_bijou_gully.asc",
}


def hillside(steepest: float | None, size: int = 300):
    """Sines of 5 m over 120 m and 190 m on 1 m cells, on a tilt making the steepest slope ``steepest`` degrees."""
    import tinsmith

    r, c = np.mgrid[0:size, 0:size]
    x, y = c + 0.5, r + 0.5
    kx, ky = 2 * np.pi / 120, 2 * np.pi / 190
    tilt = 0.0 if steepest is None else np.tan(np.radians(steepest)) - np.hypot(5 * kx, 5 * ky)
    z = 100.0 + tilt * x + 5 * np.sin(kx * x) + 5 * np.sin(ky * y)
    return tinsmith.Heightfield(z, cell_size=1.0, origin=(500000.0, 4000300.0), crs="EPSG:32610")


def grounds(hf) -> dict:
    """The two estimates of the ground, and their times."""
    import tinsmith
    from tinsmith.algorithms.urban.urban import estimate_ground

    out = {}
    for name, f in (("opening", estimate_ground), ("tinsmith.ground", tinsmith.ground)):
        start = time.perf_counter()
        out[name] = (f(hf), time.perf_counter() - start)
    return out


def share(hf, ground) -> tuple[int, float]:
    import tinsmith

    model = tinsmith.city(hf, ground=ground)
    a, b, _, d, e, _ = hf.transform
    return len(model.buildings), sum(bld.outline.area for bld in model.buildings) / (hf.n_valid * abs(a * e - b * d))


def bare_rows() -> list:
    import tinsmith

    cases = {name: tinsmith.read_heightfield(DATA / path) for name, path in BARE.items()}
    cases["hillside of sines, 17 degrees at the steepest"] = hillside(None)
    cases["hillside of sines on a tilt, 30 degrees at the steepest"] = hillside(30.0)
    rows = []
    for name, hf in cases.items():
        row = {"name": name, "cells": hf.n_valid}
        for method, (g, t) in grounds(hf).items():
            row[method] = (*share(hf, g), t)
        rows.append(row)
        print(row, flush=True)
    return rows


def city_rows() -> list:
    import urban_cities as uc

    import tinsmith

    polygons, _, _ = uc.reference()
    rows = []
    for key in ("delft_dsm", "codem", "codem_laz"):
        label, hf, ground, shares = uc.load(key)
        assert ground is None  # the runs that estimate the ground
        row = {"name": label}
        for method, (g, t) in grounds(hf).items():
            model = tinsmith.city(hf, ground=g, shares=shares)
            found = [b.outline for b in model.buildings]
            row[method] = {"n": len(found), "area": sum(p.area for p in found), "time": t,
                           **(uc.against_bgt(found, polygons) if key.startswith("delft") else {})}
        rows.append(row)
        print(row, flush=True)
    label, hf, _, _ = uc.load("delft_dsm")
    model = tinsmith.city(hf, ground=tinsmith.read_heightfield(uc.DELFT_DTM))
    found = [b.outline for b in model.buildings]
    rows.append({"name": "Delft DSM 0.5 m + DTM", "DTM": {"n": len(found), "area": sum(p.area for p in found),
                                                         **uc.against_bgt(found, polygons)}})
    return rows


def dtm_rows() -> list:
    import urban_cities as uc

    import tinsmith

    dsm = tinsmith.read_heightfield(uc.DELFT_DSM)
    dtm = tinsmith.read_heightfield(uc.DELFT_DTM)
    seen = np.abs(dsm.z - dtm.z) <= 0.3
    from tinsmith.io.points import read_clouds

    runs = {method: g for method, (g, _) in grounds(dsm).items()}
    # the LAZ itself, gridded at the DTM's cells (0.5 m, aligned alike), each cell its lowest point
    runs["tinsmith.ground of the LAZ (lowest points)"] = tinsmith.ground(read_clouds([uc.DELFT_LAZ]), cell_size=0.5)
    rows = []
    for method, g in runs.items():
        assert g.shape == dtm.shape and tuple(g.transform) == tuple(dtm.transform)
        diff = (g.z - dtm.z).astype(np.float64)
        row = {"name": method}
        for part, sel in (("all", np.ones(seen.shape, bool)), ("seen", seen), ("under", ~seen)):
            d = diff[sel & dsm.valid & g.valid]
            row[part] = (float(np.sqrt(np.mean(d * d))), float(np.percentile(np.abs(d), 95)), float(np.mean(d)))
        rows.append(row)
        print(row, flush=True)
    return rows


def bare_table(bare) -> list:
    lines = ["## Bare terrain: the area `tinsmith.city` takes as buildings, no ground given (goal 0)", "",
             "| terrain | valid cells | opening: buildings, area | tinsmith.ground: buildings, area, time (s) |",
             "|---|---|---|---|"]
    for r in bare:
        (n0, s0, _), (n1, s1, t1) = r["opening"], r["tinsmith.ground"]
        lines.append(f"| {r['name']} | {r['cells']:,} | {n0}, {100 * s0:.2f}% | {n1}, {100 * s1:.2f}%, {t1:.2f} |")
    return lines


def city_table(cities) -> list:
    lines = ["## Cities (defaults; Delft against the 160 BGT outlines inside their hull)", "",
             "| run | ground | buildings | area (m2 or ft2) | union IoU | precision | recall |", "|---|---|---|---|---|---|---|"]
    for r in cities:
        for method in ("opening", "tinsmith.ground", "DTM"):
            if method in r:
                m = r[method]
                bgt = (f"{m['union_iou']:.3f} | {m['precision']:.3f} | {m['recall']:.3f}" if "union_iou" in m
                       else "- | - | -")
                lines.append(f"| {r['name']} | {method} | {m['n']} | {m['area']:,.0f} | {bgt} |")
    return lines


def dtm_table(dtm) -> list:
    lines = ["## Delft's ground against its DTM (m): RMSE, 95th percentile of |difference|, mean difference", "",
             "| ground | every cell | where the DSM sees the ground (within 0.3 m of the DTM) | under objects |",
             "|---|---|---|---|"]
    for r in dtm:
        cells = " | ".join(f"{a:.2f}, {p:.2f}, {b:+.2f}" for a, p, b in (r["all"], r["seen"], r["under"]))
        lines.append(f"| {r['name']} | {cells} |")
    return lines


def tables(bare, cities, dtm) -> str:
    lines = ["# The ground without a DTM (`tinsmith.ground` against the grey-scale opening before it)", "",
             "Command: `python benchmarks/urban_ground.py`  ", f"{machine()}.", ""]
    lines += bare_table(bare) + [""] + city_table(cities) + [""] + dtm_table(dtm)
    return "\n".join(lines) + "\n"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", help="also write the tables to this file")
    args = ap.parse_args()
    text = tables(bare_rows(), city_rows(), dtm_rows())
    print(text)
    if args.out:
        Path(args.out).write_text(text)


if __name__ == "__main__":
    main()
