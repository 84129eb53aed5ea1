"""Parameters several commands share: class lists, point-cloud inputs."""

from __future__ import annotations

from pathlib import Path

import click

__all__ = ["cloud_inputs", "parse_classes"]


def parse_classes(ctx, param, value):
    """``--classes 2,9``: a list of class codes."""
    if value is None:
        return None
    try:
        return [int(v) for v in value.replace(" ", "").split(",") if v]
    except ValueError:
        raise click.BadParameter(f"expected class codes separated by commas, e.g. 2,9; got {value!r}") from None


def cloud_inputs(inputs) -> list | None:
    """The files of point-cloud inputs (several files, folders, globs), or None for one file of another kind."""
    from ..io.points import CLOUD_SUFFIXES, expand_sources

    if not inputs:
        return None
    if len(inputs) == 1 and Path(inputs[0]).is_file() and Path(inputs[0]).suffix.lower() not in CLOUD_SUFFIXES:
        return None
    return expand_sources(list(inputs))
