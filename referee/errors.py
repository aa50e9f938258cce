"""User-facing errors: printed as one line, exit code 2, never a traceback."""


class UserError(Exception):
    """Bad input from the user (a team spec, a level name, a path); its text is one line."""
