"""A seccomp filter that closes the kernel's key management calls to a controller.

A uid's keyrings outlive its processes (the kernel keeps the user keyring for the uid), so a
key a controller left there would reach the next controller given that uid, or fill its
quota. Under this filter add_key, request_key and keyctl fail with ENOSYS, as on a kernel
built without keys, and so does every call of another architecture's numbering (a 32-bit
entry into the kernel, x32). The template installs it in each forked controller; a spawned
sandbox gets the same program through bwrap's `--seccomp` (referee/sandbox/kernel.py).
"""

from __future__ import annotations

import ctypes
import errno
import os
import platform
import struct

# the key management calls and the architecture they are numbered for (seccomp's AUDIT_ARCH_*)
KEY_SYSCALLS = {"x86_64": (0xC000003E, (248, 249, 250)), "aarch64": (0xC00000B7, (217, 218, 219))}
PR_SET_SECCOMP, SECCOMP_MODE_FILTER, SECCOMP_RET_ALLOW, SECCOMP_RET_ERRNO = 22, 2, 0x7FFF0000, 0x00050000
BPF_LD_ABS_W, BPF_JEQ, BPF_JGE, BPF_RET = 0x20, 0x15, 0x35, 0x06
X32_SYSCALL_BIT = 0x40000000
INSTRUCTION = struct.Struct("=HBBI")  # struct sock_filter: code, jt, jf, k


def program() -> bytes | None:
    """The filter as the kernel's sock_filter array, or None on an architecture whose call
    numbers we do not know (its controllers keep the keyrings)."""
    known = KEY_SYSCALLS.get(platform.machine())
    if known is None:
        return None
    arch, calls = known
    deny = 5 + len(calls)  # the index of the denying RET below
    ops = [
        (BPF_LD_ABS_W, 0, 0, 4),  # seccomp_data.arch
        (BPF_JEQ, 0, deny - 2, arch),
        (BPF_LD_ABS_W, 0, 0, 0),  # seccomp_data.nr
        (BPF_JGE, deny - 4, 0, X32_SYSCALL_BIT),
        *((BPF_JEQ, deny - 5 - i, 0, nr) for i, nr in enumerate(calls)),
        (BPF_RET, 0, 0, SECCOMP_RET_ALLOW),
        (BPF_RET, 0, 0, SECCOMP_RET_ERRNO | errno.ENOSYS),
    ]
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
