"""The ``tinsmith`` command line (see :mod:`tinsmith.cli.main`)."""
