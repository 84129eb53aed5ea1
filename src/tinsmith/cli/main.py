"""The ``tinsmith`` command: thin, in the manner of rasterio's ``rio``.

Every command is a module-level ``click.Command`` in a module of its own
(``tinsmith.cli.simplify.simplify``, ``tinsmith.cli.city.city``, ...), a
thin parse -> API call -> report, and :data:`COMMANDS` registers them on the
group.  What they share lives in ``options.py`` (the option groups as
decorators: inputs, outputs, verbosity and JSON; the method options from the
registry), ``common.py`` (reading inputs, measuring, naming the input in
errors) and ``text.py`` (the reports).  No numerics live here.  Every failure
the user can cause ends with one line on standard error and exit code 1
(``-v`` adds the traceback).
"""

from __future__ import annotations

import signal
import sys
import threading
import traceback
import warnings

import click

from .._version import __version__
from ..errors import TinsmithError, TinsmithNote, TinsmithWarning
from ..kernels import compiling
from .city import city
from .compare import compare
from .formats import formats
from .ground import ground
from .info import info
from .lod import lod
from .methods import methods
from .metrics import metrics
from .reconstruct import reconstruct
from .remesh import remesh
from .report import report
from .samples import samples
from .serve import serve
from .simplify import simplify
from .tile import tile
from .urban import urban
from .view import view
from .warmup import warmup
from .wavelet import wavelet

#: Every command of the group, in the order of ``tinsmith --help`` (``urban``: the old name of ``city``, hidden).
COMMANDS = (simplify, lod, tile, remesh, reconstruct, city, ground, wavelet, compare, metrics, report, view, serve, info,
            methods, formats, samples, warmup, urban)

#: The commands by task, as ``tinsmith --help`` lists them.
SECTIONS = (
    ("Make meshes", ("simplify", "lod", "tile", "remesh", "reconstruct", "city", "ground", "wavelet")),
    ("Judge and look", ("compare", "metrics", "report", "view", "serve")),
    ("About", ("info", "methods", "formats", "samples", "warmup")),
)


class _Sections(click.Group):
    """A group whose help lists the commands by task."""

    def format_commands(self, ctx, formatter):
        listed = set()
        for title, names in SECTIONS:
            rows = [(n, self.commands[n].get_short_help_str(limit=80)) for n in names if n in self.commands]
            listed.update(n for n, _ in rows)
            if rows:
                with formatter.section(title):
                    formatter.write_dl(rows)
        rest = [(n, c.get_short_help_str(limit=80)) for n, c in sorted(self.commands.items())
                if n not in listed and not c.hidden]
        if rest:
            with formatter.section("Other"):
                formatter.write_dl(rest)


@click.group(cls=_Sections, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="tinsmith")
def cli():
    """tinsmith: elevation data to compact, well-shaped triangle meshes (TINs)."""


for _command in COMMANDS:
    cli.add_command(_command)


def build_cli() -> click.Group:
    """The command group (every command of :data:`COMMANDS` on it)."""
    return cli


def _show_warning(message, category, filename, lineno, file=None, line=None):
    """tinsmith's own warnings as one line on stderr; others as Python shows them."""
    if issubclass(category, TinsmithWarning):
        click.echo(f"tinsmith: warning: {message}", err=True)
    elif issubclass(category, TinsmithNote):
        click.echo(f"tinsmith: note: {message}", err=True)
    else:
        sys.stderr.write(warnings.formatwarning(message, category, filename, lineno, line))


def _terminated(signum, frame):
    """SIGTERM (a job scheduler, a container's stop, ``kill``) ends a run as Ctrl-C does."""
    raise KeyboardInterrupt


def main(argv=None) -> int:
    """Console entry point: one clear line and exit code 1 on any failure.

    SIGTERM is taken as Ctrl-C: the run stops cleanly (its process pool ended,
    no output or temporary file left, a tiled run's finished tiles kept) with
    ``tinsmith: aborted`` and exit code 1.
    """
    if threading.current_thread() is not threading.main_thread():  # signals are the main thread's
        return _main(argv)
    previous = signal.signal(signal.SIGTERM, _terminated)
    try:
        return _main(argv)
    finally:
        signal.signal(signal.SIGTERM, signal.SIG_DFL if previous is None else previous)


def _main(argv=None) -> int:
    args = sys.argv[1:] if argv is None else list(argv)
    verbose = "-v" in args or "--verbose" in args
    # a first run may compile kernels for a minute: say so on standard error rather than sit silent
    compiling.announce_with(lambda message: click.echo(f"tinsmith: {message}", err=True))
    cli = build_cli()
    try:
        with warnings.catch_warnings():
            warnings.showwarning = _show_warning
            code = cli.main(args=args, prog_name="tinsmith", standalone_mode=False)
        return code if isinstance(code, int) else 0
    except click.exceptions.Exit as exc:
        return exc.exit_code
    except (click.exceptions.Abort, KeyboardInterrupt):  # Ctrl-C or SIGTERM (click turns them into Abort)
        click.echo("tinsmith: aborted", err=True)
        return 1
    except click.ClickException as exc:  # usage errors: unknown option, missing argument, ...
        command = f" {exc.ctx.info_name}" if getattr(exc, "ctx", None) and exc.ctx.parent else ""
        click.echo(f"tinsmith{command}: error: {exc.format_message()}", err=True)
        return 1
    except (TinsmithError, OSError, MemoryError) as exc:
        if verbose:
            traceback.print_exc()
        click.echo(f"tinsmith: error: {exc}", err=True)
        return 1
    except Exception as exc:  # a bug: still one line, the traceback with -v
        if verbose:
            traceback.print_exc()
        click.echo(
            f"tinsmith: internal error: {type(exc).__name__}: {exc} (run with -v for the traceback)", err=True
        )
        return 1
