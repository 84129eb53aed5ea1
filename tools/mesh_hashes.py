"""Hash the mesh of every method on shared data, to check that a refactoring changes no mesh.

    python tools/mesh_hashes.py -o before.json       # on the old tree
    python tools/mesh_hashes.py --check before.json  # on the new one: lists every mesh that differs

Each entry hashes the vertices, the triangles and every per-vertex and
per-triangle array the mesh carries (compared by value, so a renamed
attribute still matches).  Runs on the embedded sample, a window of Big
Tujunga (bare terrain) and a window of the Delft DSM (a city), through the
public API, with the names that work before and after a rename (a
deprecated name warns and still works; a deprecated method is hashed by
its old name as long as it runs).  A key only the new run has (a method
added since) is listed as new, not as a difference.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import sys
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT.parent / "shared" / "data"


def _arrays(mesh) -> list[str]:
    """Digests of the mesh's per-vertex and per-triangle arrays, sorted (names may change)."""
    n_v, n_t = len(mesh.vertices), len(mesh.triangles)
    found = []
    stores = [getattr(mesh, "info", {}) or {}]
    for name in ("vertex_attributes", "triangle_attributes"):
        store = getattr(mesh, name, None)
        if store:
            stores.append(dict(store))
    for store in stores:
        for value in store.values():
            if isinstance(value, np.ndarray) and value.ndim >= 1 and len(value) in (n_v, n_t) and value.dtype != object:
                found.append(hashlib.sha256(np.ascontiguousarray(value).tobytes()).hexdigest()[:16])
    return sorted(set(found))


def _digest(mesh) -> dict:
    mesh = getattr(mesh, "mesh", mesh)  # a city model: its mesh
    h = hashlib.sha256()
    h.update(np.ascontiguousarray(mesh.vertices, dtype=np.float64).tobytes())
    h.update(np.ascontiguousarray(mesh.triangles, dtype=np.int64).tobytes())
    return {"mesh": h.hexdigest()[:16], "n_vertices": len(mesh.vertices), "arrays": _arrays(mesh)}


def _jobs():
    import tinsmith

    sample = tinsmith.sample("st-helens")
    tujunga = tinsmith.read_heightfield(DATA / "terrain/big_tujunga_canyon/srtm_bigtujunga30m_utm11.tif")
    delft = tinsmith.read_heightfield(DATA / "urban/delft_ahn3/delft_dsm_0.5m.tif")

    pieces = {"st-helens": sample,
              "tujunga": _crop(tujunga, 200, 200),
              "delft": _crop(delft, 240, 240)}
    for label, hf in pieces.items():
        lo, hi = np.nanmin(hf.z), np.nanmax(hf.z)
        bound = float(hi - lo) / 40
        try:
            listed = tinsmith.methods(deprecated=True)  # deprecated methods too, by their old names
        except TypeError:  # a tree from before deprecated methods
            listed = tinsmith.methods()
        for method in listed:
            name = method.name
            if method.input == "points":
                continue
            data = tinsmith.simplify(hf, method="grid") if method.input == "surface" else hf
            if name in ("remesh", "cvt"):
                kwargs = {"max_vertices": 400}
            elif name in ("urban", "wavelet", "grid", "blocks"):
                kwargs = {}
            else:
                kwargs = {"max_error": bound}
            yield f"{label}/{name}", lambda data=data, name=name, kwargs=kwargs: tinsmith.simplify(data, method=name, **kwargs)
        yield f"{label}/greedy-budget", lambda hf=hf: tinsmith.simplify(hf, max_vertices=2000)
        yield f"{label}/city", lambda hf=hf: tinsmith.city(hf)
    yield "delft/city-solid", lambda: tinsmith.city(pieces["delft"], solid=True)
    yield "st-helens/greedy-default", lambda: tinsmith.simplify(sample)
    cloud = tinsmith.read(DATA / "terrain/lidR_forest_lakes/Topography.laz")
    yield "topography/reconstruct", lambda: tinsmith.reconstruct(cloud)
    yield "topography/tin", lambda: tinsmith.tin(cloud)
    yield "topography/greedy", lambda: tinsmith.simplify(cloud, method="greedy", max_error=0.5)


def _crop(hf, rows: int, cols: int):
    from tinsmith.core import Heightfield

    r0, c0 = hf.shape[0] // 3, hf.shape[1] // 3
    z = np.array(hf.z[r0:r0 + rows, c0:c0 + cols])
    a, b, c, d, e, f = hf.transform[:6]
    transform = (a, b, c + a * c0 + b * r0, d, e, f + d * c0 + e * r0)
    return Heightfield(z, transform=transform, crs=hf.crs, nodata=hf.nodata)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("-o", "--output", type=Path)
    ap.add_argument("--check", type=Path)
    args = ap.parse_args()
    from tinsmith.errors import TinsmithError

    warnings.simplefilter("ignore")
    result = {}
    for key, job in _jobs():
        try:
            result[key] = _digest(job())
        except TinsmithError as exc:  # a refused input: the refusal is compared as well
            result[key] = {"error": str(exc)}
        print(key, result[key], flush=True)
    if args.output:
        args.output.write_text(json.dumps(result, indent=1, sort_keys=True) + "\n")
    if args.check:
        before = json.loads(args.check.read_text())
        new = sorted(set(result) - set(before))
        differ = [k for k in sorted(set(before) | set(result)) if k not in new and before.get(k) != result.get(k)]
        for k in new:
            print(f"NEW {k}: {result[k]}")
        for k in differ:
            print(f"DIFFERS {k}: {before.get(k)} -> {result.get(k)}")
        print(f"{len(before) - len(differ)} of {len(before)} meshes the same bit for bit; {len(new)} new")
        return 1 if differ else 0
    return 0


if __name__ == "__main__":
    sys.exit(main())
