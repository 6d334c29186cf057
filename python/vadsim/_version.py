"""The package version, from one source: the installed distribution's metadata, which
scikit-build-core writes from ``pyproject.toml``."""

from importlib import metadata

try:
    __version__: str = metadata.version("vadsim")
except metadata.PackageNotFoundError:  # a source tree that was never installed
    __version__ = "0+unknown"
