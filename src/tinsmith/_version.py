"""The installed version of tinsmith."""

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("tinsmith")
except PackageNotFoundError:  # pragma: no cover - running from a source tree without install
    __version__ = "0+unknown"
