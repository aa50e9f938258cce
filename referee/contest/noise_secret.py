"""The noise secret of a grade or a tournament: a new one written to a file (`laserarena secret
new`), one read from a file (`--secret-file`) or given to the Python API, each judged before
use (referee.contest.secret_strength), and what derives from it: its public id and each
match's noise key (docs/integrity.md).
"""

from __future__ import annotations

import hashlib
import hmac
import os
import secrets
from pathlib import Path

from referee.contest.secret_strength import weakness
from referee.errors import UserError

MAX_FILE = 4096  # bytes: a secret file is a line; a larger file (or /dev/zero) is no secret
HOW = "make one with `laserarena secret new FILE`"


def secret_id(secret: str) -> str:
    """A public name for a secret (sha256-based): it tells runs apart, reveals nothing."""
    return hashlib.sha256(b"laserarena-secret-id:" + secret.encode()).hexdigest()[:16]


def noise_key(secret: str, level_hash: str, seed: int) -> str:
    """The per-match noise key: HMAC-SHA256 of the level and seed under the run's secret."""
    return hmac.new(secret.encode(), f"laserarena-noise:{level_hash}:{seed}".encode(), hashlib.sha256).hexdigest()


def checked(secret: str, where: str) -> str:
    """`secret` itself if it is strong enough, else a UserError naming `where` (never the
    secret): a weak secret would let a team recover the noise by guessing it."""
    problem = weakness(secret)
    if problem:
        raise UserError(f"{where}: {problem}; {HOW}")
    return secret


def read(path: str | Path) -> str:
    """The secret held in the file at `path`, its text without the white space around it,
    checked (`checked`). Any file that can be read will do, a pipe too (`<(...)`)."""
    try:
        with open(path, "rb") as f:
            data = f.read(MAX_FILE + 1)
    except OSError as e:
        raise UserError(f"{path}: cannot read the secret: {e.strerror or e}") from None
    if len(data) > MAX_FILE:
        raise UserError(f"{path}: more than {MAX_FILE} bytes, not a secret file; {HOW}")
    try:
        text = data.decode("utf-8").strip()
    except UnicodeDecodeError:
        raise UserError(f"{path}: not UTF-8 text, not a secret file; {HOW}") from None
    if not text:
        raise UserError(f"{path}: the secret file is empty; {HOW}")
    return checked(text, str(path))


def create(path: Path, replace: bool = False) -> None:
    """Write a new secret to `path`: 256 random bits from `secrets`, as 64 hex digits. The file
    is made 0600 by the call that creates it (O_EXCL: never another's file, never readable by
    others for a moment). An existing `path` is refused unless `replace`; then the new file is
    made beside it and renamed over it, so the old secret stays whole until the new one is."""
    text = (secrets.token_hex(32) + "\n").encode()
    made = path.with_name(f".{path.name}.{secrets.token_hex(4)}.new") if replace else path
    flags = os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW | getattr(os, "O_CLOEXEC", 0)
    try:
        fd = os.open(made, flags, 0o600)
    except FileExistsError:
        raise UserError(f"{path}: exists; --force replaces it") from None
    except OSError as e:
        raise UserError.of(e) from None
    try:
        try:
            if hasattr(os, "fchmod"):  # POSIX: exactly 0600, whatever the umask took off
                os.fchmod(fd, 0o600)
            os.write(fd, text)
            os.fsync(fd)
        finally:
            os.close(fd)
        if replace:
            os.replace(made, path)
    except BaseException:
        made.unlink(missing_ok=True)
        raise
