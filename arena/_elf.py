"""The symbols an ELF object file defines, read from its symbol table (arena.compiled loads a
cached kernel's machine code by them, without parsing the kernel's LLVM bitcode)."""

from __future__ import annotations

import struct

__all__ = ["defined_symbols"]

SHT_SYMTAB = 2  # a section holding a symbol table
SHN_UNDEF = 0  # a symbol's section index when the object only refers to it
STT_SECTION, STT_FILE = 3, 4  # symbol types that name a section or the source file, no code or data
_HEADER = struct.Struct("<QIHHHHHH")  # e_shoff .. e_shstrndx, from byte 0x28
_SECTION = struct.Struct("<IIQQQQIIQQ")  # Elf64_Shdr
_SYMBOL = struct.Struct("<IBBHQQ")  # Elf64_Sym


def defined_symbols(obj: bytes) -> set[str] | None:
    """The names of the functions and variables `obj` defines (as LLVM lists a module's
    definitions), or None where `obj` is no 64-bit little-endian ELF object this can read
    (macOS, Windows, a file cut short: the caller then asks LLVM)."""
    if obj[:4] != b"\x7fELF" or obj[4:6] != b"\x02\x01":  # ELFCLASS64, ELFDATA2LSB
        return None
    try:
        return _symbols(obj)
    except (struct.error, IndexError, ValueError):  # a table that runs past the file, a name not UTF-8
        return None


def _symbols(obj: bytes) -> set[str]:
    """`defined_symbols` of an ELF64 little-endian object, read from its symbol tables."""
    shoff, _, _, _, _, shentsize, shnum, _ = _HEADER.unpack_from(obj, 0x28)
    sections = [_SECTION.unpack_from(obj, shoff + i * shentsize) for i in range(shnum)]
    names: set[str] = set()
    for _, kind, _, _, offset, size, link, _, _, entsize in sections:
        if kind != SHT_SYMTAB or not entsize:
            continue
        strings = sections[link][4]  # the string table's offset in the file
        for at in range(offset, offset + size, entsize):
            name, info, _, section, _, _ = _SYMBOL.unpack_from(obj, at)
            if name and section != SHN_UNDEF and info & 0xF not in (STT_SECTION, STT_FILE):
                start = strings + name
                names.add(obj[start : obj.index(b"\0", start)].decode())
    return names
