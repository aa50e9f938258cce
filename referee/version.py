"""The laserarena version, recorded in every result and replay; the package's own version
(pyproject.toml reads it from here)."""

__version__ = "0.2.0"
