"""The options of the land-use wavelet filter, shared by `tinsmith wavelet` and `simplify --prefilter wavelet`."""

from __future__ import annotations

import click

from ..algorithms.wavelet.wavelet_table import ROLES, TABLE_1

#: Option names (as click passes them) that belong to the filter.
NAMES = ("landuse", "role", "attribute", "spline_iterations", "delta", "variant", "window", "bridge_extension",
         "replace_tolerance", "replace", "flatten_water", "threshold_rows")


#: The same options as the registry names them (method "wavelet"): the flags above give them, for the method too.
REGISTRY_NAMES = ("landuse", "roles", "attribute", "spline_iterations", "delta", "variant", "window", "bridge_extension",
                  "replace_tolerance", "replace", "flatten_water", "thresholds")


def _parse_roles(ctx, param, value):
    if not value:
        return None
    roles = {}
    for item in value:
        key, sep, role = item.rpartition(":")
        if not sep or not key or role not in ROLES:
            raise click.BadParameter(
                f"expected KEY:ROLE with a role of {', '.join(ROLES)} (e.g. waterdeel:water or bgt_type=kademuur:shoreline), "
                f"got {item!r}"
            )
        roles[key] = role
    return roles


def _parse_rows(ctx, param, value):
    if not value:
        return None
    rows = {}
    for item in value:
        name, sep, numbers = item.partition("=")
        if not sep or name not in TABLE_1:
            raise click.BadParameter(f"expected ROW=t0,t1,... with a row of {', '.join(TABLE_1)}, got {item!r}")
        try:
            rows[name] = [float(v) for v in numbers.split(",") if v.strip()]
        except ValueError:
            raise click.BadParameter(f"{item!r}: the thresholds must be numbers separated by commas") from None
    return rows


def _parse_iterations(ctx, param, value):
    if value is None or value == "auto":
        return value
    try:
        return int(value)
    except ValueError:
        raise click.BadParameter(f"expected 'auto' or a whole number, got {value!r}") from None


def _parse_variant(ctx, param, value):
    return None if value == "none" else int(value)


def wavelet_options(func=None, *, required: bool = True):
    """The filter's options; ``required``: --landuse must be given (else it may be left out)."""
    if func is None:
        return lambda f: wavelet_options(f, required=required)
    decorators = [
        click.option("--landuse", metavar="FILE", required=required, type=click.Path(dir_okay=False),
                     help="Land-use polygons (any vector format GDAL reads): shorelines, embankments, bridges, streets, "
                          "water, forest."),
        click.option("--role", "role", multiple=True, metavar="KEY:ROLE", callback=_parse_roles,
                     help="A layer name, usage value or field=value, and its role (repeat; replaces the BGT defaults)."),
        click.option("--attribute", metavar="NAME", help="The usage column whose values --role keys name."),
        click.option("--spline-iterations", default="auto", show_default=True, callback=_parse_iterations,
                     help="Coarsenings of the spline approximation, or auto: the count of fewest triangles (1 to 6)."),
        click.option("--delta", type=float, default=4.0, show_default=True,
                     help="Class 2: points whose height departs from the spline by more (z units)."),
        click.option("--variant", type=click.Choice(["4", "3", "none"]), default="4", show_default=True,
                     callback=_parse_variant, help="The Haar low pass: formula 4, formula 3, or none (unfiltered detail)."),
        click.option("--window", type=int, default=9, show_default=True,
                     help="Side, in grid points, of the square that makes a point near a feature (class 1)."),
        click.option("--bridge-extension", type=float, default=2.0, show_default=True,
                     help="Grow bridges by this much (world units)."),
        click.option("--replace-tolerance", type=float, default=0.3, show_default=True,
                     help="Low-pass heights replace spline heights only where they differ by more (z units)."),
        click.option("--replace", type=click.Choice(["soft", "hard"]), default="soft", show_default=True,
                     help="hard: the paper's switch; soft: the difference shrunk by the tolerance, without steps."),
        click.option("--flatten-water/--no-flatten-water", default=True, show_default=True,
                     help="Flatten each water body to its mean height."),
        click.option("--thresholds", "threshold_rows", multiple=True, metavar="ROW=t0,t1,...", callback=_parse_rows,
                     help=f"Replace a row of Table 1 ({', '.join(TABLE_1)}), coarsest level first (repeat)."),
    ]
    for decorator in reversed(decorators):
        func = decorator(func)
    return func


def wavelet_kwargs(opts: dict) -> dict:
    """Take the filter's options out of the parsed options, as keywords of :func:`tinsmith.wavelet_filter`."""
    o = {name: opts.pop(name) for name in NAMES}
    return {
        "landuse": o["landuse"], "roles": o["role"], "attribute": o["attribute"],
        "spline_iterations": o["spline_iterations"], "delta": o["delta"], "variant": o["variant"],
        "window": o["window"], "bridge_extension": o["bridge_extension"], "replace_tolerance": o["replace_tolerance"],
        "replace": o["replace"], "flatten_water": o["flatten_water"], "thresholds": o["threshold_rows"],
    }
