"""``--streams`` and ``--boundary``: the mesh's outline cut into a flood solver's named segments.

The options read vector files of lines; :func:`tinsmith.segment_outline`
does the work after meshing, before any output is written.
"""

from __future__ import annotations

from pathlib import Path

import click

#: Where the segments go: the formats whose writers carry node strings.
CARRIED_BY = "2DM, Gmsh (.msh), ADCIRC (fort.14, .14, .grd) and TELEMAC (.slf and its .cli)"


def segment_options(func):
    """The two options, ``streams`` (a file or None) and ``boundaries`` (the NAME=FILE texts)."""
    func = click.option(
        "--boundary", "boundaries", multiple=True, metavar="NAME=FILE",
        help="A named boundary segment: the border edges along the lines of FILE take NAME, over the inflows, "
             "outflows and walls (repeat for several; a later one over an earlier one).")(func)
    return click.option(
        "--streams", "streams", type=click.Path(dir_okay=False), metavar="FILE",
        help="Cut the outline into solver boundary segments: inflow_N / outflow_N where the stream lines of FILE "
             f"cross it, wall_N elsewhere, hole_N round holes; written as node strings to {CARRIED_BY}.")(func)


def parse(streams, boundaries) -> dict[str, str] | None:
    """``{option label: file}`` of the lines to read (``"--streams"`` and ``"--boundary NAME"``), or None
    when neither option is given; every file read once here, so that a missing file or one without lines
    fails before any meshing."""
    files = {}
    if streams is not None:
        files["--streams"] = streams
    for text in boundaries:
        name, sep, path = text.partition("=")
        if not sep:
            raise click.UsageError(f"--boundary takes NAME=FILE, got {text!r}")
        if not name.strip():
            raise click.UsageError(f"--boundary takes NAME=FILE with a non-empty NAME, got {text!r}")
        if not path:
            raise click.UsageError(f"--boundary takes NAME=FILE with a file, got {text!r}")
        if f"--boundary {name}" in files:
            raise click.UsageError(f"--boundary gives the name {name!r} twice")
        files[f"--boundary {name}"] = path
    for label, path in files.items():
        if not Path(path).is_file():
            raise click.UsageError(f"{label}: file {path!r} does not exist")
        if not _count_lines(path, label):
            raise click.UsageError(f"{label}: {path!r} holds no lines")
    return files or None


def _count_lines(path, label) -> int:
    import shapely

    from ..io.geometry import load

    n = 0
    for feats in load(path, label, "lines"):
        geoms = feats.geometries[~shapely.is_missing(feats.geometries)]
        n += int(sum(shapely.get_type_id(p) in (1, 2) for p in shapely.get_parts(geoms)))
    return n


def note_outputs(files, outputs) -> None:
    """One note line when some output carries no node strings (the segments go to the solver formats only)."""
    from ..io import writer_for

    if files and any(not writer_for(out).solver for out in outputs):
        click.echo(f"tinsmith: note: the boundary segments are written only to {CARRIED_BY} outputs", err=True)


def apply(mesh, files):
    """``mesh`` with its outline cut into segments (:func:`tinsmith.segment_outline`); a ``flood`` mesh cut by the
    same ``--streams`` already (the method took them) is kept as it is, so the file is not read twice."""
    import shapely

    if set(files) == {"--streams"} and mesh.info.get("flood", {}).get("streams_derived") is False:
        return mesh

    from ..io.boundaries import _stream_lines, segment_outline

    lines = {}
    for label, path in files.items():
        if label.startswith("--boundary "):
            parts = [shapely.LineString(p) for p in _stream_lines(path, label, mesh)]
            merged = shapely.line_merge(shapely.MultiLineString(parts)) if len(parts) > 1 else parts[0]
            lines[label[len("--boundary "):]] = merged
    return segment_outline(mesh, streams=files.get("--streams"), lines=lines or None)
