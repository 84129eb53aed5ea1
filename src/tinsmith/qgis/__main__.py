"""``python -m tinsmith.qgis install [--profile NAME] [--qgis-dir DIR]``: the plugin into a QGIS profile."""

from __future__ import annotations

import argparse
import sys

from .plugin import PLUGIN, install


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python -m tinsmith.qgis",
                                     description="Install tinsmith's QGIS plugin (its Processing provider).")
    commands = parser.add_subparsers(dest="command", required=True)
    put = commands.add_parser("install", help=f"write the {PLUGIN} plugin into a QGIS profile")
    put.add_argument("--profile", default="default", help="QGIS profile (default: %(default)s)")
    put.add_argument("--qgis-dir", help="QGIS 3's settings folder (default: this user's, e.g. ~/.local/share/QGIS/QGIS3)")
    args = parser.parse_args(argv)
    try:
        folder = install(args.profile, args.qgis_dir)
    except OSError as exc:
        print(f"tinsmith: error: cannot install the QGIS plugin: {exc}", file=sys.stderr)
        return 1
    print(f"installed {folder}; enable 'tinsmith' in QGIS under Plugins > Manage and Install Plugins")
    return 0


if __name__ == "__main__":
    sys.exit(main())
