"""``tinsmith info``, ``methods``, ``formats``, ``samples`` and ``warmup``: what there is, and getting ready."""

from __future__ import annotations

import click

from ..algorithms.registry import DEFAULT_METHOD, methods
from ..io import (
    read,
)
from ..kernels import compiling
from ..samples import SAMPLES
from .common import (
    inputs_of,
    read_options,
    verbose_json,
)
from .report import (
    describe_data,
    describe_survey,
    echo_json,
    format_info,
    num,
)


def add_commands(group: click.Group) -> None:
    """Add this module's command(s) to ``group``."""

    @group.command()
    @click.argument("files", metavar="FILE...", nargs=-1)
    @read_options(gridding=False)
    @verbose_json
    def info(files, verbose, as_json, **opts):
        """Describe a raster, point cloud or mesh: size, CRS, z range, nodata; a survey of many clouds from their headers."""
        path, label = inputs_of(files, opts.pop("sample"))
        report = describe_survey(files, path) if isinstance(path, list) else describe_data(read(path, **opts), label)
        echo_json(report) if as_json else click.echo(format_info(report))

    @group.command("methods")
    @verbose_json
    def methods_cmd(verbose, as_json):
        """List the methods with their options."""
        records = [
            {
                "name": m.name,
                "description": m.description,
                "input": m.input,
                "stop_rules": list(m.stop_rules),
                "exact_budget": m.exact_budget,
                "options": [
                    {"name": o.name, "type": o.type.__name__, "default": o.default, "doc": o.describe()}
                    for o in m.options
                ],
                "paper": m.paper,
                "default": m.name == DEFAULT_METHOD,
            }
            for m in methods()
        ]
        if as_json:
            echo_json({"methods": records})
            return
        for r in records:
            flag = " (default)" if r["default"] else ""
            click.echo(f"{r['name']}{flag}: {r['description']}")
            if r["stop_rules"]:
                click.echo("  stop rules: " + ", ".join("--" + s.replace("_", "-") for s in r["stop_rules"])
                           + (" (the number of vertices it places)" if r["exact_budget"] else ""))
            for o in r["options"]:
                click.echo(f"  --{o['name'].replace('_', '-')} ({o['type']}): {o['doc']}")
            if r["paper"]:
                click.echo(f"  from: {r['paper']}")

    @group.command()
    @click.option("--jobs", metavar="J1,J2,...",
                  help="Warm up only these jobs: default (the README's first command), methods, points, city, "
                       "filters, reconstruct, tiles.")
    def warmup(jobs):
        """Compile every numerical kernel now, once, so that later runs start at once.

        The package ships the compiled kernels of these jobs for the numba, Python and platform it
        was built with; elsewhere (or after a kernel changes) they compile on first use and are
        cached. This runs each job once on a small piece of the sample.
        """
        from ..warmup import JOBS
        from ..warmup import warmup as run

        names = [j for j in jobs.replace(" ", "").split(",") if j] if jobs else None

        def say(name):
            click.echo(f"{name}: {JOBS[name][0]} ...", err=True)

        seconds = run(names, progress=say)
        count, spent = compiling.compiled()
        click.echo(f"warmed up {', '.join(seconds)} in {num(sum(seconds.values()))} s; "
                   f"{count} kernel(s) compiled ({num(spent)} s), the rest loaded from the cache")

    @group.command()
    @verbose_json
    def samples(verbose, as_json):
        """List the embedded sample datasets (use them with --sample NAME)."""
        rows = [{"name": s.name, "description": s.description, "licence": s.licence} for s in SAMPLES.values()]
        if as_json:
            echo_json({"samples": rows})
            return
        for r in rows:
            click.echo(f"{r['name']}: {r['description']} [{r['licence']}]")

    @group.command()
    @verbose_json
    def formats(verbose, as_json):
        """List the file formats tinsmith reads and writes."""
        from ..io import READERS, WRITERS

        readers = {}
        for suffix, rec in READERS.items():
            readers.setdefault(rec.description, {"kind": rec.kind, "suffixes": [], "options": list(rec.options)})
            readers[rec.description]["suffixes"].append(suffix)
        writers = {}
        for suffix, rec in WRITERS.items():
            writers.setdefault(rec.description, {"suffixes": [], "crs": "embedded" if rec.carries_crs else ".prj sidecar"})
            writers[rec.description]["suffixes"].append(suffix)
        if as_json:
            echo_json({"readers": readers, "writers": writers})
            return
        click.echo("read:")
        for desc, r in readers.items():
            suffixes = " ".join(s if s != "*" else "(any other GDAL raster)" for s in r["suffixes"])
            click.echo(f"  {suffixes}: {desc} [{r['kind']}]")
        click.echo("write:")
        for desc, w in writers.items():
            click.echo(f"  {' '.join(w['suffixes'])}: {desc} [CRS: {w['crs']}]")
