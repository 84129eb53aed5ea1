"""``tinsmith urban``: the old name of ``tinsmith city``, hidden from the help; it says so in one note line."""

from __future__ import annotations

import click

from .city import city


def _urban(**kwargs):
    click.echo("tinsmith: note: 'tinsmith urban' is now 'tinsmith city' (the same options); "
               "the old name goes in a later release", err=True)
    return city.callback(**kwargs)


urban = click.Command("urban", callback=_urban, params=city.params, help=city.help, short_help=city.short_help,
                      context_settings=city.context_settings, hidden=True)
