"""``tinsmith warmup``: compile the numerical kernels now, so that later runs start at once."""

from __future__ import annotations

import click

from ..kernels import compiling
from .text import num


@click.command()
@click.option("--jobs", metavar="J1,J2,...",
              help="Warm up only these jobs: default (the README's first command), methods, points, city, "
                   "filters, hydrology, reconstruct, tiles.")
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
