"""The fork server's words, written once for both ends: the template (`template`) and the
referee's client of it (referee/sandbox/forkserver.py). Each word is one byte on a socket."""

from __future__ import annotations

import struct

READY = b"r"  # template -> referee, on its control socket: imported, ready to fork
FORK = b"f"  # referee -> template, on the control socket, with a slot's watch and settings sockets
KILL = b"k"  # referee -> template, on a slot's watch: end that controller
ENDED = b"s"  # template -> referee, on the watch: the controller ended; STATUS follows
FAILED = b"e"  # template -> referee, on the watch: the slot could not be made; a message follows
STATUS = struct.Struct("<id")  # after ENDED: exit status (bwrap's convention), CPU seconds used
