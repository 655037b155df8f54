"""The compiled kernels must not use BLAS: numba's matrix products and np.linalg need scipy,
which is not a runtime dependency (the quick start installs without it)."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

CORE = Path(__file__).resolve().parents[1] / "bowlrec" / "core"
#: every module of the core that compiles a kernel or a kernel helper
KERNEL_MODULES = sorted(p.stem for p in CORE.glob("*.py") if "@njit" in p.read_text())
FORBIDDEN = re.compile(r"[\w)\]]\s*@\s*[\w(]|np\.linalg\.|np\.dot\(|np\.outer\(|\.dot\(")


@pytest.mark.parametrize("module", KERNEL_MODULES)
def test_kernel_module_uses_no_blas(module: str) -> None:
    offending = []
    for lineno, line in enumerate((CORE / f"{module}.py").read_text().splitlines(), 1):
        code = line.split("#", 1)[0]
        if '"""' in line or code.strip().startswith(('"', "'")):
            continue
        if FORBIDDEN.search(code):
            offending.append(f"{module}.py:{lineno}: {line.strip()}")
    assert not offending, offending
