"""The seccomp filter every sandboxed controller runs under: the calls a controller never needs
and that reach past its slot's bounds are denied.

How it works, in detail: docs/internals.md, `robots/_host/seccomp.py`.
"""

from __future__ import annotations

import ctypes
import errno
import functools
import os
import platform
import struct
from collections.abc import Callable

# the calls' numbers per architecture (x86-64, then arm64's generic table)
CALLS = {
    "add_key": (248, 217),
    "request_key": (249, 218),
    "keyctl": (250, 219),
    "fallocate": (285, 47),
    "io_uring_setup": (425, 425),
    "io_uring_enter": (426, 426),
    "io_uring_register": (427, 427),
    "unshare": (272, 97),
    "setns": (308, 268),
    "clone3": (435, 435),
    "mount": (165, 40),
    "umount2": (166, 39),
    "pivot_root": (155, 41),
    "chroot": (161, 51),
    "open_tree": (428, 428),
    "move_mount": (429, 429),
    "fsopen": (430, 430),
    "fsconfig": (431, 431),
    "fsmount": (432, 432),
    "fspick": (433, 433),
    "mount_setattr": (442, 442),
    "bpf": (321, 280),
    "perf_event_open": (298, 241),
    "userfaultfd": (323, 282),
    "setsid": (112, 157),
    "setpgid": (109, 154),
    "sched_setaffinity": (203, 122),
    "clone": (56, 220),  # the rest are judged by an argument (ARGUMENT_CHECKED)
    "socket": (41, 198),
    "socketpair": (53, 199),
    "fcntl": (72, 25),
}
AF_UNIX, F_SETPIPE_SZ = 1, 1031
ARG_LOW = (16, 24)  # offsets of the low 32 bits of seccomp_data.args[0] and args[1] (little-endian)
# call: (its argument, how it is judged, the value, the error when denied); `set`: denied when
# any of the value's bits is set; `equal`: denied when equal; `other`: denied unless equal
ARGUMENT_CHECKED = {
    "clone": (
        0,
        "set",
        0x7E020000,
        errno.EPERM,
    ),  # CLONE_NEWNS | NEWCGROUP | NEWUTS | NEWIPC | NEWUSER | NEWPID | NEWNET
    "socket": (0, "other", AF_UNIX, errno.EAFNOSUPPORT),
    "socketpair": (0, "other", AF_UNIX, errno.EAFNOSUPPORT),
    "fcntl": (1, "equal", F_SETPIPE_SZ, errno.EPERM),
}
ERRORS = {
    **dict.fromkeys(("add_key", "request_key", "keyctl", "io_uring_setup", "io_uring_enter"), errno.ENOSYS),
    **dict.fromkeys(("io_uring_register", "clone3"), errno.ENOSYS),
    "fallocate": errno.EOPNOTSUPP,
}  # every other denied call: EPERM
ARCHES = {"x86_64": (0xC000003E, 0), "aarch64": (0xC00000B7, 1)}  # AUDIT_ARCH_*, column of CALLS
PR_SET_SECCOMP, SECCOMP_MODE_FILTER, SECCOMP_RET_ALLOW, SECCOMP_RET_ERRNO = 22, 2, 0x7FFF0000, 0x00050000
BPF_LD_ABS_W, BPF_JEQ, BPF_JGE, BPF_JSET, BPF_RET = 0x20, 0x15, 0x35, 0x45, 0x06
X32_SYSCALL_BIT = 0x40000000
INSTRUCTION = struct.Struct("=HBBI")  # struct sock_filter: code, jt, jf, k


def _ret(error: int | None) -> tuple[int, int, int, int]:
    return (BPF_RET, 0, 0, SECCOMP_RET_ALLOW if error is None else SECCOMP_RET_ERRNO | error)


@functools.cache
def program() -> bytes | None:
    """The filter as the kernel's sock_filter array, or None on an architecture whose call
    numbers we do not know (its controllers run unfiltered). Built once per process (the
    controller template builds it before it forks)."""
    known = ARCHES.get(platform.machine())
    if known is None:
        return None
    arch, column = known
    denied = {name: numbers[column] for name, numbers in CALLS.items() if name not in ARGUMENT_CHECKED}
    # layout: arch check, x32 check, one (JEQ, RET) pair per denied call, five instructions per
    # call judged by an argument (JEQ, load it, judge, RET error, RET allow), allow, and the
    # foreign-numbering RET at the end
    foreign = 4 + 2 * len(denied) + 5 * len(ARGUMENT_CHECKED) + 1  # the index of the last RET
    ops = [
        (BPF_LD_ABS_W, 0, 0, 4),  # seccomp_data.arch
        (BPF_JEQ, 0, foreign - 2, arch),
        (BPF_LD_ABS_W, 0, 0, 0),  # seccomp_data.nr
        (BPF_JGE, foreign - 4, 0, X32_SYSCALL_BIT),
    ]
    for name, nr in denied.items():  # this call: its error; else skip that RET
        ops += [(BPF_JEQ, 0, 1, nr), _ret(ERRORS.get(name, errno.EPERM))]
    for name, (arg, how, value, error) in ARGUMENT_CHECKED.items():
        judge = {"set": (BPF_JSET, 0, 1), "equal": (BPF_JEQ, 0, 1), "other": (BPF_JEQ, 1, 0)}[how]
        ops += [
            (BPF_JEQ, 0, 4, CALLS[name][column]),  # another call: on to the next check
            (BPF_LD_ABS_W, 0, 0, ARG_LOW[arg]),
            (judge[0], judge[1], judge[2], value),  # true: to the error (jt 0), false: allowed
            _ret(error),
            _ret(None),
        ]
    ops += [_ret(None), _ret(errno.ENOSYS)]
    assert len(ops) == foreign + 1
    return b"".join(INSTRUCTION.pack(*op) for op in ops)


class _SockFprog(ctypes.Structure):
    _fields_ = [("len", ctypes.c_ushort), ("filter", ctypes.c_char_p)]


@functools.cache
def prepare() -> Callable[[], int] | None:
    """The call that installs the filter, its program and arguments made (once per process: the
    controller template prepares it before it forks); None where there is no filter."""
    code = program()
    if code is None:
        return None
    prog = _SockFprog(len(code) // INSTRUCTION.size, code)  # its `filter` points into `code`, cached
    prctl = ctypes.CDLL(None, use_errno=True).prctl
    return functools.partial(prctl, PR_SET_SECCOMP, ctypes.c_ulong(SECCOMP_MODE_FILTER), ctypes.byref(prog), 0, 0)


def install() -> None:
    """Put this process (and whatever it starts) under the filter; needs no-new-privs or
    CAP_SYS_ADMIN. OSError if the kernel refuses it."""
    call = prepare()
    if call is not None and call() != 0:
        raise OSError(ctypes.get_errno(), f"seccomp filter: {os.strerror(ctypes.get_errno())}")
