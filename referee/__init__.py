"""The authority: match loop, controller processes, rules, scoring, replays, grading, CLI."""

from importlib import metadata

try:
    __version__ = metadata.version("laserarena")
except metadata.PackageNotFoundError:  # running from a source tree that was never installed
    __version__ = "0+unknown"
