"""Human-readable text for the CLI's reports (the JSON reports are the same dicts)."""

from __future__ import annotations

import json
import math
import numbers
import sys

import click

from .. import core
from ..io.crs import describe

__all__ = ["describe_data", "describe_survey", "echo_json", "format_comparison", "format_metrics", "format_timings", "num"]


def num(value, digits: int = 3) -> str:
    """A number for people: thousands separators for counts, ``digits`` significant digits otherwise."""
    if value is None:
        return "-"
    if isinstance(value, numbers.Integral):  # int and numpy's integers
        return f"{int(value):,}"
    value = float(value)
    if math.isnan(value):
        return "n/a"
    if value == 0:
        return "0"
    return f"{value:.{digits}g}" if abs(value) < 1e6 else f"{value:,.0f}"


def _plain(obj):
    if isinstance(obj, dict):
        return {str(k): _plain(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_plain(v) for v in obj]
    np = sys.modules.get("numpy")  # no numpy scalar exists before numpy is imported
    if np is not None and isinstance(obj, np.generic):
        obj = obj.item()
    if isinstance(obj, float) and not math.isfinite(obj):
        return None  # JSON has no NaN/inf
    return obj


def echo_json(data: dict) -> None:
    click.echo(json.dumps(_plain(data), indent=2))


def describe_data(data, path: str) -> dict:
    """What ``tinsmith info`` reports for a heightfield, point cloud or mesh."""
    if isinstance(data, core.Heightfield):
        lo, hi = data.z_range
        return {
            "file": path,
            "kind": "raster",
            "rows": data.shape[0],
            "cols": data.shape[1],
            "cells": data.n_cells,
            "cell_size": list(data.cell_size),
            "bounds": list(data.bounds),
            "crs": describe(data.crs),
            "dtype": data.source_dtype,
            "z_min": lo,
            "z_max": hi,
            "nodata_cells": data.n_cells - data.n_valid,
            "nodata_share": data.nodata_fraction,
        }
    if isinstance(data, core.PointCloud):
        return {
            "file": path,
            "kind": "points",
            "points": len(data),
            "classes": data.class_counts(),
            "bounds": list(data.bounds),
            "crs": describe(data.crs),
        }
    if isinstance(data, core.TerrainMesh):
        problems = data.check()
        return {
            "file": path,
            "kind": "mesh",
            "vertices": data.n_vertices,
            "triangles": data.n_triangles,
            "bounds": list(data.bounds),
            "crs": describe(data.crs),
            "valid": not problems,
            "problems": problems,
        }
    raise TypeError(type(data))  # pragma: no cover


def describe_survey(given, files) -> dict:
    """What ``tinsmith info`` reports for several point-cloud files: their headers summed (no point read)."""
    import numpy as np

    from ..io.points import clouds_info

    infos, crs = clouds_info(files)
    b = np.array([i.bounds for i in infos if i.count]).reshape(-1, 6)
    bounds = [float(b[:, k].min()) for k in range(3)] + [float(b[:, k].max()) for k in range(3, 6)] if len(b) else []
    return {"file": " ".join(str(g) for g in given), "kind": "survey", "files": len(infos),
            "points": int(sum(i.count for i in infos)), "bounds": bounds, "crs": describe(crs),
            "largest_file": max(i.count for i in infos) if infos else 0}


def _bounds(b) -> str:
    return ", ".join(f"{v:.10g}" for v in b)


def format_info(d: dict) -> str:
    lines = [f"{d['file']}: {d['kind']}"]
    if d["kind"] == "raster":
        lines += [
            f"  size: {d['rows']:,} rows x {d['cols']:,} cols ({d['cells']:,} cells), dtype {d['dtype']}",
            f"  cell size: {num(d['cell_size'][0], 6)} x {num(d['cell_size'][1], 6)}",
            f"  crs: {d['crs']}",
            "  bounds: " + _bounds(d["bounds"]),
            f"  z range: {num(d['z_min'], 6)} .. {num(d['z_max'], 6)}",
            f"  nodata: {d['nodata_cells']:,} cells ({100 * d['nodata_share']:.2f}%)",
        ]
    elif d["kind"] == "points":
        classes = ", ".join(f"{c}: {k:,}" for c, k in d["classes"].items()) or "none"
        lines += [
            f"  points: {d['points']:,}",
            f"  classes: {classes}",
            f"  crs: {d['crs']}",
            "  bounds: " + _bounds(d["bounds"]),
        ]
    elif d["kind"] == "survey":
        lines += [
            f"  files: {d['files']:,} point clouds, {d['points']:,} points (the largest file {d['largest_file']:,})",
            f"  crs: {d['crs']}",
            "  bounds: " + (_bounds(d["bounds"]) if d["bounds"] else "none (no points)"),
        ]
    else:
        lines += [
            f"  vertices: {d['vertices']:,}, triangles: {d['triangles']:,}",
            f"  crs: {d['crs']}",
            "  bounds: " + _bounds(d["bounds"]),
            "  valid triangulation: " + ("yes" if d["valid"] else "no: " + "; ".join(d["problems"])),
        ]
    return "\n".join(lines)


def format_error(e: dict, of: str = "valid cells") -> str:
    return (
        f"max {num(e['max'])}, RMS {num(e['rmse'])}, mean |e| {num(e['mean_abs'])}, "
        f"bias {num(e['bias'])}, p99 {num(e['p99'])}; coverage {100 * e['coverage']:.2f}% "
        f"of {e['n_valid']:,} {of}"
    )


def format_quality(q: dict) -> str:
    def trio(d):
        return f"{num(d['min'])} / {num(d['median'])} / {num(d['max'])}"

    return (
        f"min angle {trio(q['min_angle'])} deg, max angle {trio(q['max_angle'])} deg, "
        f"aspect ratio {trio(q['aspect_ratio'])} (min / median / max); "
        f"{100 * q['share_min_angle_below_20']:.2f}% of triangles under 20 deg"
    )


def format_metrics(m: dict, of: str = "valid cells") -> str:
    lines = [f"  vertices: {m['n_vertices']:,}, triangles: {m['n_triangles']:,}"]
    if "vertical_error" in m:
        lines.append("  vertical error (z units): " + format_error(m["vertical_error"], of))
    lines.append("  quality 3-D: " + format_quality(m["quality_3d"]))
    lines.append("  quality 2-D: " + format_quality(m["quality_2d"]))
    return "\n".join(lines)


def format_timings(timings: dict) -> str:
    return "  timings: " + ", ".join(f"{k} {v:.3f} s" for k, v in timings.items())


_COMPARISON_COLUMNS = (
    ("method", "method"), ("n_vertices", "vertices"), ("n_triangles", "triangles"), ("max_error", "max error"),
    ("rmse", "RMS error"), ("coverage", "coverage"), ("min_angle", "min angle (deg)"),
    ("max_aspect_ratio", "max aspect ratio"), ("time", "time (s)"),
)


def format_comparison(rows: list[dict], markdown: bool = False) -> str:
    """The rows of :func:`tinsmith.algorithms.compare_methods` as an aligned or a Markdown table."""
    header = [title for _, title in _COMPARISON_COLUMNS]
    body = [
        [r["method"]]
        + [f"{100 * r[k]:.2f}%" if k == "coverage" and r[k] is not None else num(r[k]) for k, _ in _COMPARISON_COLUMNS[1:]]
        for r in rows
    ]
    notes = [f"{r['method']}: {r['error']}" for r in rows if r.get("error")]
    if markdown:
        lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
        lines += ["| " + " | ".join(cells) + " |" for cells in body]
        return "\n".join(lines + ([""] + notes if notes else []))
    widths = [max(len(h), *(len(b[i]) for b in body)) for i, h in enumerate(header)]
    fmt = "  ".join(f"{{:<{widths[0]}}}" if i == 0 else f"{{:>{w}}}" for i, w in enumerate(widths))
    return "\n".join([fmt.format(*cells) for cells in [header, *body]] + notes)
