"""Every grid method under the same vertex budget: the measured version of the Salt Lake City thesis' Table 2.1.

    pip install -e ".[test]"
    python benchmarks/compare_methods.py          # writes benchmarks/RESULTS_compare.md

For St. Helens, Big Tujunga and the Delft DTM (0.5 m), at 1% and 5% of the
valid cells: `tinsmith.compare_methods` runs each registered method with stop
rules (the same as `tinsmith compare --max-vertices N`) and judges every mesh
by the same metrics: counts, max and RMS vertical error, coverage, the
smallest angle, the largest aspect ratio and the method's time.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from _common import HERE, SHARED, machine

DATA = SHARED / "data"

DEMS = [
    ("St. Helens 30 m", None),
    ("Big Tujunga 30 m", DATA / "terrain/big_tujunga_canyon/srtm_bigtujunga30m_utm11.tif"),
    ("Delft DTM 0.5 m", DATA / "urban/delft_ahn3/delft_dtm_0.5m.tif"),
]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--shares", type=float, nargs="+", default=[0.01, 0.05], help="vertex budgets as shares of the valid cells")
    ap.add_argument("--out", default=str(HERE / "RESULTS_compare.md"))
    args = ap.parse_args()

    import tinsmith
    from tinsmith.cli.report import format_comparison

    names = [m.name for m in tinsmith.methods() if m.stop_rules]
    lines = [
        "# Grid methods side by side (the Salt Lake City thesis, Table 2.1, measured)",
        "",
        "Command: `python benchmarks/compare_methods.py`  ",
        f"{machine()}. Errors in metres against every valid cell; time is the method alone, its kernels loaded first.",
    ]
    for label, path in DEMS:
        hf = tinsmith.sample("st-helens") if path is None else tinsmith.read_heightfield(path)
        for share in args.shares:
            budget = max(4, int(share * hf.n_valid))
            rows = tinsmith.compare_methods(hf, names, max_vertices=budget)
            h, w = hf.shape
            lines += ["", f"## {label}, {h} x {w} ({hf.n_valid:,} valid cells), max_vertices {budget:,} ({share:.0%})", ""]
            lines.append(format_comparison(rows, markdown=True))
            print(label, share, [(r["method"], r["n_vertices"], r["max_error"]) for r in rows], flush=True)
    Path(args.out).write_text("\n".join(lines) + "\n")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
