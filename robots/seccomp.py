"""The seccomp filter every sandboxed controller runs under: a few system calls denied.

- the kernel's keyrings (add_key, request_key, keyctl fail with ENOSYS, as on a kernel built
  without keys): a uid's keyrings outlive its processes, so a key a controller left there
  would reach the next controller given that uid, or fill its quota;
- fallocate (EOPNOTSUPP: the C library then writes instead, within the file-size limit): its
  log is the referee's file, open for writing, and fallocate's KEEP_SIZE reserves the host's
  disk blocks without the file growing, past any file-size limit.

Every call made through another architecture's numbering (a 32-bit entry into the kernel,
x32), which the filter cannot read, fails with ENOSYS. The template installs the filter in each
forked controller; a spawned sandbox gets the same program through bwrap's `--seccomp`
(referee/sandbox/kernel.py). docs/decisions/0024-seccomp-filter-not-an-allowlist.md says why
no more.
"""

from __future__ import annotations

import ctypes
import errno
import os
import platform
import struct

# per architecture: seccomp's AUDIT_ARCH_* value and the denied calls' numbers with their errors
KEYS = (errno.ENOSYS,) * 3
DENIED = {
    "x86_64": (0xC000003E, dict(zip((248, 249, 250, 285), (*KEYS, errno.EOPNOTSUPP)))),
    "aarch64": (0xC00000B7, dict(zip((217, 218, 219, 47), (*KEYS, errno.EOPNOTSUPP)))),
}
PR_SET_SECCOMP, SECCOMP_MODE_FILTER, SECCOMP_RET_ALLOW, SECCOMP_RET_ERRNO = 22, 2, 0x7FFF0000, 0x00050000
BPF_LD_ABS_W, BPF_JEQ, BPF_JGE, BPF_RET = 0x20, 0x15, 0x35, 0x06
X32_SYSCALL_BIT = 0x40000000
INSTRUCTION = struct.Struct("=HBBI")  # struct sock_filter: code, jt, jf, k


def program() -> bytes | None:
    """The filter as the kernel's sock_filter array, or None on an architecture whose call
    numbers we do not know (its controllers run unfiltered)."""
    known = DENIED.get(platform.machine())
    if known is None:
        return None
    arch, calls = known
    foreign = 5 + 2 * len(calls)  # the index of the last RET: a call of another numbering
    ops = [
        (BPF_LD_ABS_W, 0, 0, 4),  # seccomp_data.arch
        (BPF_JEQ, 0, foreign - 2, arch),
        (BPF_LD_ABS_W, 0, 0, 0),  # seccomp_data.nr
        (BPF_JGE, foreign - 4, 0, X32_SYSCALL_BIT),
    ]
    for nr, error in calls.items():  # this call: its error; else skip that RET
        ops += [(BPF_JEQ, 0, 1, nr), (BPF_RET, 0, 0, SECCOMP_RET_ERRNO | error)]
    ops += [(BPF_RET, 0, 0, SECCOMP_RET_ALLOW), (BPF_RET, 0, 0, SECCOMP_RET_ERRNO | errno.ENOSYS)]
    return b"".join(INSTRUCTION.pack(*op) for op in ops)


class _SockFprog(ctypes.Structure):
    _fields_ = [("len", ctypes.c_ushort), ("filter", ctypes.c_char_p)]


def install() -> None:
    """Put this process (and whatever it starts) under the filter; needs no-new-privs or
    CAP_SYS_ADMIN. OSError if the kernel refuses it."""
    code = program()
    if code is None:
        return
    prog = _SockFprog(len(code) // INSTRUCTION.size, code)
    libc = ctypes.CDLL(None, use_errno=True)
    if libc.prctl(PR_SET_SECCOMP, ctypes.c_ulong(SECCOMP_MODE_FILTER), ctypes.byref(prog), 0, 0) != 0:
        raise OSError(ctypes.get_errno(), f"seccomp filter: {os.strerror(ctypes.get_errno())}")
