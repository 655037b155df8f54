"""A kernel library loaded from numba's cache without parsing its linking bitcode.

numba caches a CPU kernel as its machine code (an object file) and, beside it, the LLVM bitcode
of the whole kernel, kept so that another kernel compiled later can inline this one. Loading
parses that bitcode at once (2.4 MB for ``simulate_kernel``: ~0.23 s, a quarter of a fresh
``bowlrec simulate``) for two uses: the names of the symbols the library defines (so numba can
find the kernel's entry points in the JIT engine) and, rarely, linking into a new kernel.

:class:`lean_library_class` gives numba's library class a variant whose load takes the defined
symbols from the object file's own symbol table (ELF: the global and weak symbols it defines,
which are the bitcode's non-private definitions) and parses the bitcode only when a kernel
compiled later links this one. The machine code run is the cached object either way. Object
files other than 64-bit little-endian ELF relocatables (macOS, Windows), a bitcode kind other
than ``object``, or a numba whose classes lack what this relies on take numba's own load.

:func:`bowlrec.core._kernel_cache.load_lean` installs it for the duration of a kernel's load.
"""

from __future__ import annotations

import functools
import struct
from typing import Any

__all__ = ["elf_defined_symbols", "lean_library_class"]

_SHT_SYMTAB = 2
_STB_GLOBAL, _STB_WEAK = 1, 2
_SHN_UNDEF = 0


def elf_defined_symbols(obj: bytes) -> set[str] | None:
    """Names of the global and weak symbols a 64-bit little-endian ELF relocatable object
    defines; None for any other or a malformed file."""
    try:
        if obj[:4] != b"\x7fELF" or obj[4] != 2 or obj[5] != 1:  # ELFCLASS64, little-endian
            return None
        (e_type,) = struct.unpack_from("<H", obj, 0x10)
        if e_type != 1:  # ET_REL
            return None
        (e_shoff,) = struct.unpack_from("<Q", obj, 0x28)
        e_shentsize, e_shnum = struct.unpack_from("<HH", obj, 0x3A)
        sections = [
            struct.unpack_from("<IIQQQQIIQQ", obj, e_shoff + i * e_shentsize)
            for i in range(e_shnum)
        ]
        names: set[str] = set()
        for sh in sections:
            if sh[1] != _SHT_SYMTAB:
                continue
            offset, size, link, entsize = sh[4], sh[5], sh[6], sh[9]
            strings = sections[link][4]
            for k in range(size // entsize):
                st_name, st_info, _, st_shndx, _, _ = struct.unpack_from(
                    "<IBBHQQ", obj, offset + k * entsize
                )
                if st_shndx == _SHN_UNDEF or st_info >> 4 not in (_STB_GLOBAL, _STB_WEAK):
                    continue
                start = strings + st_name
                names.add(obj[start : obj.index(b"\0", start)].decode())
        return names
    except (struct.error, IndexError, ValueError, UnicodeDecodeError):
        return None


@functools.cache
def lean_library_class(base: type) -> type | None:
    """``base`` (numba's JIT code library class) with the lean load (the module doc); None when
    ``base`` lacks what it relies on."""
    needed = (
        "_unserialize",
        "enable_object_caching",
        "_set_compiled_object",
        "_finalize_final_module",
        "_get_module_for_linking",
    )
    if not all(hasattr(base, name) for name in needed):
        return None
    import llvmlite.binding as ll

    class LeanLibrary(base):  # type: ignore[misc, valid-type]
        """A code library whose linking module is parsed when first asked for."""

        @property
        def _shared_module(self) -> Any:
            state = self.__dict__
            module = state.get("_lean_shared_module")
            if module is None and state.get("_lean_bitcode") is not None:
                module = ll.parse_bitcode(state.pop("_lean_bitcode"))
                state["_lean_shared_module"] = module
            return module

        @_shared_module.setter
        def _shared_module(self, module: Any) -> None:
            self.__dict__["_lean_shared_module"] = module

        @classmethod
        def _unserialize(cls, codegen: Any, state: Any) -> Any:
            name, kind, data = state
            known = getattr(getattr(codegen, "_engine", None), "_defined_symbols", None)
            symbols = elf_defined_symbols(data[0]) if kind == "object" else None
            if symbols is None or not isinstance(known, set):
                return super()._unserialize(codegen, state)
            object_code, shared_bitcode = data
            library = codegen.create_library(name)
            if type(library) is not cls:
                library.__class__ = cls
            library.enable_object_caching()
            library._set_compiled_object(object_code)
            library.__dict__["_lean_bitcode"] = shared_bitcode
            library._finalize_final_module()
            known |= symbols  # what numba's load reads from the parsed bitcode
            return library

    return LeanLibrary
