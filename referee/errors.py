"""The referee's errors, one hierarchy under `levels.errors.LaserArenaError`, and their exit codes.

Every error path of the command line ends in one of these: `referee.cli.main` prints the one
line and exits with the error's `exit_code` (docs/cli.md lists the codes).

- `levels.loader.LevelError`: a level file (file:line: key: message);
- `TeamError`: a team spec or a team's files that cannot be resolved;
- `ReplayError`: a replay that cannot be read (also a ValueError, for library callers);
- `JournalError`: a grading journal that cannot be read or written;
- `SandboxError`: the controllers cannot be started as promised on this machine;
- `UserError`: any other bad argument or path on the command line (usage).
"""

from __future__ import annotations

from levels.errors import LaserArenaError

EXIT_OK, EXIT_FAILED, EXIT_BAD_INPUT, EXIT_INTERRUPTED, EXIT_PIPE = 0, 1, 2, 130, 141  # docs/cli.md


class LaserArenaWarning(UserWarning):
    """Something the user should know that does not stop the command (`warnings.warn`: a
    library caller filters it as any Python warning; the command line prints it as
    `laserarena: warning: ...`, and `run --quiet` keeps it quiet)."""


class UserError(LaserArenaError):
    """A bad argument, value or path given on the command line or to the Python API."""

    @classmethod
    def of(cls, e: Exception) -> UserError:
        """The one line for a file that could not be read: `PATH: reason` for an OSError that
        names its file (not Python's `[Errno 2] ...`), else the exception's own words."""
        if isinstance(e, OSError) and e.filename is not None:
            return cls(f"{e.filename}: {e.strerror or e}")
        return cls(str(e))


class TeamError(LaserArenaError):
    """A team spec that names nothing loadable, or whose files cannot be shipped."""


class ReplayError(LaserArenaError, ValueError):
    """A file that is not a readable LaserArena replay (damaged, truncated, another version)."""


class JournalError(LaserArenaError):
    """A grading journal that is corrupt, foreign, or cannot be written."""


class SandboxError(LaserArenaError):
    """Controllers cannot be isolated as promised here (say, the install is closed to them)."""
