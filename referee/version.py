"""The installed laserarena version, recorded in every result and replay."""

from importlib import metadata

try:
    __version__ = metadata.version("laserarena")
except metadata.PackageNotFoundError:  # running from a source tree that was never installed
    __version__ = "0+unknown"
