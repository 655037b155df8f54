"""Drop stale numba caches of the kernels before any of them is compiled or loaded.

numba keys a cached function on its own source file only, so a kernel would keep a stale copy of
a function it calls from another file (e.g. the integrator inlines ``dynamics.rhs``). To rule that
out, the cached kernels are dropped whenever any source file of ``bowlrec/core`` differs from the
one the cache was built from (one hash over the sources, cheap beside loading a kernel). ``vec``
imports this module, and every kernel module imports ``vec``, so it runs once, before the first
kernel loads.
"""

from __future__ import annotations

import hashlib
from pathlib import Path


def _drop_stale_kernel_cache() -> None:
    here = Path(__file__).parent
    digest = hashlib.sha256()
    for source in sorted(here.glob("*.py")):
        digest.update(source.name.encode())
        digest.update(source.read_bytes())
    stamp_text = digest.hexdigest()
    cache = here / "__pycache__"
    stamp = cache / "bowlrec-core-sources.sha256"
    try:
        if stamp.exists() and stamp.read_text() == stamp_text:
            return
        cache.mkdir(exist_ok=True)
        for stale in list(cache.glob("*.nbi")) + list(cache.glob("*.nbc")):
            stale.unlink(missing_ok=True)
        stamp.write_text(stamp_text)
    except OSError:
        pass  # read-only install: numba then falls back to its own behaviour


_drop_stale_kernel_cache()
