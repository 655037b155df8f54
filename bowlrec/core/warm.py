"""Load (or compile) the compiled kernels a process needs, before its first real delivery.

    python -m bowlrec.core.warm [NAME ...] [--jobs N]

:func:`warm_up` runs each named kernel variant once on a small delivery, so numba loads it from
its on-disk cache (or compiles it and writes the cache when the entry is missing or stale:
``bowlrec.core._kernel_cache``), and reports the time and how many kernels it compiled and
loaded. A name is a variant of :data:`VARIANTS` or a group of :data:`GROUPS`:

* ``closed_form``: the closed form (uniform ball, summary only);
* ``integrator``, ``steps``, ``rate``: the integrator recording the summary only, every step with
  the equation terms, samples at a fixed rate (one compiled signature; the three run its three
  recording paths); each also loads the helper deriving forces and energies from samples, which
  a summary-only run does not call;
* ``observe``: the integrator with observed stations and turns (bowlers' reports, aim);
* ``batch_serial``, ``batch_parallel``: the many-delivery kernel on one thread, on all threads;
* groups: ``service`` (what a request, a job run in the server process and a session shot use:
  closed form, integrator, serial batch), ``batch`` (what a batch's worker runs: the serial
  batch kernel, which holds the closed form and the integrator compiled into it, and the
  integrator for the runs it records in full), ``all`` (every variant above).

``extra`` kernels (name -> function) run after the named ones: that is how
``bowlrec.testing.warm`` adds the paper's RK4 scheme, which ``bowlrec.core`` may not import.

The command warms the named kernels (default ``all``) and prints one line: seconds, kernels
compiled, kernels loaded. ``--jobs N`` splits the work over N processes, each compiling a
disjoint part of the variants (see :func:`warm_up_in_processes`: measured in
benchmarks/results/kernel_cache.md). ``bowlrec warm`` is the same with a progress bar.

:func:`missing` tells, without importing numba, which variants numba's on-disk cache lacks for
the current sources (each variant's :data:`ENTRIES`: the kernels it calls from Python, with the
signatures it needs): what the commands' first-use notice asks before they load kernels.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable, Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np

from bowlrec.errors import UnavailableError

from .codes import RECORD_RATE, RECORD_STEPS, RECORD_SUMMARY
from .plan import Plan

__all__ = [
    "ENTRIES",
    "GROUPS",
    "VARIANTS",
    "Entry",
    "WarmUp",
    "WarmUpError",
    "compile_seconds",
    "kernel_counts",
    "missing",
    "offset_plan",
    "split",
    "uniform_plan",
    "warm_up",
    "warm_up_in_processes",
]


def uniform_plan() -> Plan:
    """A uniform ball on a two-zone oil pattern, summary only (the closed form applies)."""
    return Plan(
        mass_kg=6.8,
        radius_m=0.1085,
        inertia_per_mass_m2=np.full(3, 0.4 * 0.1085**2),
        r_delta_body_m=np.zeros(3),
        q0=np.array([1.0, 0.0, 0.0, 0.0]),
        position0_m=np.array([0.0, 0.5334]),
        velocity0_mps=np.array([8.0, 0.0]),
        omega0_radps=np.array([0.0, 30.0, 0.0]),
        lane_length_m=18.288,
        lane_width_m=1.0668,
        friction_x_edges_m=np.array([12.192]),
        friction_y_edges_m=np.array([0.10668, 0.96012]),
        friction_mu=np.array([[0.2, 0.04, 0.2], [0.2, 0.2, 0.2]]),
        rtol=1e-6,
        record_mode=RECORD_SUMMARY,
    )


def offset_plan() -> Plan:
    """An asymmetric ball with its center of mass off the center and tilted spin (integrator)."""
    return dataclasses.replace(
        uniform_plan(),
        inertia_per_mass_m2=np.array([0.066, 0.067, 0.068]) ** 2,
        r_delta_body_m=np.array([0.0, -0.0005, 0.0]),
        q0=np.array([0.9, 0.1, 0.3, 0.2]) / np.linalg.norm([0.9, 0.1, 0.3, 0.2]),
        omega0_radps=np.array([-16.62, 23.74, 7.765]),
    )


def _closed_form() -> None:
    from .arguments import use_closed_form
    from .solver import solve

    plan = uniform_plan()
    assert use_closed_form(plan)
    solve(plan)


def _integrator(**changes: Any) -> Callable[[], None]:
    def run() -> None:
        from .arguments import use_closed_form
        from .solver import solve

        plan = dataclasses.replace(offset_plan(), **changes)
        assert not use_closed_form(plan)
        solve(plan)
        if plan.record_mode == RECORD_SUMMARY:  # no samples: the solve derived nothing
            solve(dataclasses.replace(plan, record_mode=RECORD_RATE, record_dt_s=0.5))

    return run


def _observe() -> None:
    from .solver import solve

    solve(offset_plan(), stations_m=(4.0, 12.0), turns=True)


def _batch(parallel: bool) -> Callable[[], None]:
    def run() -> None:
        from .batch import pack_plans, run_batch

        run_batch(pack_plans([uniform_plan(), offset_plan()]), parallel=parallel)

    return run


#: every kernel variant by name: a function that runs it once on a small delivery
VARIANTS: dict[str, Callable[[], None]] = {
    "closed_form": _closed_form,
    "integrator": _integrator(),
    "steps": _integrator(record_mode=RECORD_STEPS, record_terms=True),
    "rate": _integrator(record_mode=RECORD_RATE, record_dt_s=0.01),
    "observe": _observe,
    "batch_serial": _batch(parallel=False),
    "batch_parallel": _batch(parallel=True),
}

#: named sets of variants, by the process that needs them
GROUPS: dict[str, tuple[str, ...]] = {
    "service": ("closed_form", "integrator", "batch_serial"),
    "batch": ("integrator", "batch_serial"),
    "all": tuple(VARIANTS),
}


class Entry(NamedTuple):
    """A kernel of ``bowlrec/core`` a variant calls from Python: its module (file stem), its
    function, and what the signature it needs has at some argument positions: (position, the
    start of the argument's numba type name), e.g. ``(15, "none")``: no observed stations."""

    module: str
    function: str
    args: tuple[tuple[int, str], ...] = ()


#: the kernels each variant calls from Python (numba keeps what they call compiled into them);
#: ``integrator`` is the summary-only run (``warm_up`` also loads the helper deriving forces
#: and energies for it, which only a run recording samples calls)
_SIMULATE = Entry("integrator", "simulate_kernel", ((15, "none"),))
_SAMPLED = (_SIMULATE, Entry("derive", "derive_samples"))
ENTRIES: dict[str, tuple[Entry, ...]] = {
    "closed_form": (Entry("closed_form", "closed_form_kernel"),),
    "integrator": (_SIMULATE,),
    "steps": _SAMPLED,
    "rate": _SAMPLED,
    "observe": (Entry("integrator", "simulate_kernel", ((15, "array"),)),),
    "batch_serial": (Entry("batch", "_run_serial"),),
    "batch_parallel": (Entry("batch", "_run_parallel"),),
}


def missing(*names: str, cache_dir: Path | None = None) -> list[str]:
    """The variants of ``names`` (variants or groups; none: ``all``) that would compile now: a
    kernel of theirs (:data:`ENTRIES`) has no entry of the signature they need in numba's cache
    for its current source (``cache_dir``, default the one numba uses for ``bowlrec/core``).
    Imports no numba when the cache is current or empty; when bowlrec's stamp of the cache is
    out of date (the sources changed), runs the check that drops the stale entries first
    (:func:`~bowlrec.core._kernel_cache.check_core`, which imports numba). [] when numba has no
    cache directory it can write."""
    from . import _kernel_cache as kc

    chosen = expand(names or ("all",), {})
    core = Path(__file__).parent
    cache = kc.numba_cache_dir(core) if cache_dir is None else Path(cache_dir)
    if cache is None:
        return []
    if not (cache / kc.STAMP).is_file():  # numba has written nothing for these sources
        return chosen
    if not kc.stamp_current(core, cache):
        kc.check_core() if cache_dir is None else kc.drop_stale_kernels(core, cache)
    found: dict[tuple[str, str], list[tuple[Any, ...]]] = {}

    def cached(entry: Entry) -> bool:
        key = (entry.module, entry.function)
        if key not in found:
            found[key] = kc.cached_signatures(cache, core / f"{entry.module}.py", entry.function)
        return any(
            all(pos < len(sig) and str(sig[pos]).startswith(start) for pos, start in entry.args)
            for sig in found[key]
        )

    return [name for name in chosen if not all(cached(e) for e in ENTRIES[name])]


class WarmUpError(UnavailableError, RuntimeError):
    """A kernel variant failed to compile or run (its error is the cause): the compiled kernels
    are not available."""


@dataclasses.dataclass(frozen=True)
class WarmUp:
    """What :func:`warm_up` did: the variants it ran, wall and CPU seconds (this process, or
    the sum over the processes of :func:`warm_up_in_processes`), and the kernels (compiled
    signatures of numba dispatchers, callees included) compiled and loaded from numba's cache."""

    names: tuple[str, ...]
    seconds: float
    cpu_seconds: float
    compiled: int
    loaded: int
    jobs: int = 1

    def __str__(self) -> str:
        where = f" in {self.jobs} processes" if self.jobs > 1 else ""
        return (
            f"kernel warm-up: {self.seconds:.1f} s{where} ({self.cpu_seconds:.1f} s CPU), "
            f"{self.compiled} kernels compiled, {self.loaded} loaded from numba's cache"
        )

    def as_dict(self) -> dict[str, Any]:
        return dataclasses.asdict(self)


def kernels() -> list[Any]:
    """Every numba kernel (dispatcher) defined by the bowlrec modules loaded in this process;
    none when numba is not loaded."""
    if "numba" not in sys.modules:
        return []
    from numba.core.registry import CPUDispatcher

    return [
        obj
        for name, module in list(sys.modules.items())
        if name.startswith("bowlrec.") and module is not None
        for obj in list(vars(module).values())
        if isinstance(obj, CPUDispatcher) and obj.__module__ == name
    ]


def kernel_counts() -> tuple[int, int]:
    """(compiled, loaded): the signatures numba compiled and loaded from its cache so far, over
    every kernel of the bowlrec modules loaded in this process."""
    compiled = loaded = 0
    for kernel in kernels():
        compiled += sum(kernel.stats.cache_misses.values())
        loaded += sum(kernel.stats.cache_hits.values())
    return compiled, loaded


def _cpu_seconds() -> float:
    usage = resource.getrusage(resource.RUSAGE_SELF)
    return usage.ru_utime + usage.ru_stime


def expand(names: Iterable[str], extra: Mapping[str, Callable[[], object]]) -> list[str]:
    """The variants ``names`` stand for, in order, each once (``all``: ``extra`` too)."""
    out: list[str] = []
    for name in names:
        group = (*GROUPS["all"], *extra) if name == "all" else GROUPS.get(name, (name,))
        for variant in group:
            if variant not in VARIANTS and variant not in extra:
                known = ", ".join([*GROUPS, *VARIANTS, *extra])
                raise ValueError(f"unknown kernel variant {variant!r} (known: {known})")
            if variant not in out:
                out.append(variant)
    return out


def warm_up(
    *names: str,
    extra: Mapping[str, Callable[[], object]] | None = None,
    jobs: int = 1,
    module: str = __name__,
    progress: Callable[[str, bool], None] | None = None,
) -> WarmUp:
    """Load or compile the kernel variants ``names`` (variants or groups, see the module doc;
    none: ``all``). ``extra``: more variants (name -> a function that runs them once), run when
    named or when ``all`` is. ``jobs`` > 1: in that many fresh processes at once
    (:func:`warm_up_in_processes` of ``python -m module``, which must know the same ``extra``).
    ``progress(name, done)`` is called as each variant starts (False) and ends (True). A variant
    that fails raises :class:`WarmUpError` naming it. Returns what it did (:class:`WarmUp`).

    >>> warm_up("service")  # doctest: +SKIP
    WarmUp(names=('closed_form', 'integrator', 'batch_serial'), seconds=0.41, ...)
    """
    extra = dict(extra or {})
    chosen = expand(names or ("all",), extra)
    if jobs > 1:
        return warm_up_in_processes(split(chosen, jobs), module, progress)
    start, cpu = time.perf_counter(), _cpu_seconds()
    compiled0, loaded0 = kernel_counts()
    for name in chosen:
        if progress is not None:
            progress(name, False)
        try:
            (extra.get(name) or VARIANTS[name])()
        except Exception as err:
            raise WarmUpError(f"kernel variant {name} failed: {err!r}") from err
        if progress is not None:
            progress(name, True)
    compiled, loaded = kernel_counts()
    return WarmUp(
        names=tuple(chosen),
        seconds=time.perf_counter() - start,
        cpu_seconds=_cpu_seconds() - cpu,
        compiled=compiled - compiled0,
        loaded=loaded - loaded0,
    )


#: variants that share compiled signatures: a part of :func:`split` runs a unit whole
_UNITS = (("batch_serial", "batch_parallel"), ("integrator", "steps", "rate"))
#: rough CPU seconds of a variant's first compile after the ones before it in ``all`` (estimates
#: for balancing the parts; what the split achieves is in benchmarks/results/kernel_cache.md); a
#: variant not listed counts 10
_COST = {
    "batch_serial": 40,
    "batch_parallel": 60,
    "integrator": 45,
    "observe": 30,
    "closed_form": 25,
}


def _units(names: Sequence[str]) -> list[list[str]]:
    """``names`` grouped into the units of :data:`_UNITS` (variants alone otherwise)."""
    units = [[n for n in names if n in unit] for unit in _UNITS]
    return [u for u in units if u] + [[n] for n in names if not any(n in u for u in _UNITS)]


def compile_seconds(names: Sequence[str]) -> float:
    """A rough CPU time (s) of compiling the variants ``names`` from an empty cache: the
    estimates of :data:`_COST`, once per unit of variants sharing signatures."""
    units = [next((u for u in _UNITS if n in u), (n,)) for n in names]
    return sum(max(_COST.get(n, 10) for n in unit) for unit in dict.fromkeys(units))


def split(names: Sequence[str], jobs: int) -> list[list[str]]:
    """``names`` in at most ``jobs`` disjoint parts of about equal compile cost: the units of
    variants sharing signatures, costliest first, each to the part with the least so far."""
    units = _units(names)
    units.sort(key=lambda u: -sum(_COST.get(n, 10) for n in u))
    parts: list[list[str]] = [[] for _ in range(max(1, jobs))]
    load = [0] * len(parts)
    for unit in units:
        i = load.index(min(load))
        parts[i] += unit
        load[i] += sum(_COST.get(n, 10) for n in unit)
    return [p for p in parts if p]


def _lock_cache_writes(lock: str) -> None:
    """Serialize numba's cache writes with the other processes holding ``lock``.

    numba adds an entry by reading a function's ``.nbi`` index, picking the next free data
    file number and writing both back (each file atomically, ``os.replace``; numba/core/
    caching.py, ``IndexDataCacheFile.save``). Two processes adding different signatures of one
    function at once (``push_event`` has 14) can both pick number 1: one entry is lost, or the
    index names the data file of the other signature. Reading stays unlocked: a reader sees an
    index and data files written whole, and a missing data file makes it compile."""
    import fcntl

    from numba.core.caching import IndexDataCacheFile

    save = IndexDataCacheFile.save

    def locked_save(self: Any, key: Any, data: Any) -> None:
        fd = os.open(lock, os.O_RDWR | os.O_CREAT, 0o600)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX)
            save(self, key, data)
        finally:
            os.close(fd)  # releases the lock

    IndexDataCacheFile.save = locked_save  # type: ignore[method-assign]


def warm_up_in_processes(
    parts: Sequence[Sequence[str]],
    module: str = __name__,
    progress: Callable[[str, bool], None] | None = None,
) -> WarmUp:
    """Warm disjoint ``parts`` (lists of names) at once, one fresh ``python -m module`` process
    each, their writes to numba's cache serialized (:func:`_lock_cache_writes`; ``module``'s
    command must be :func:`main`). ``progress`` as in :func:`warm_up`, from the processes'
    reports (called from one thread per process). A process that fails (its errors go to this
    process's stderr) raises :class:`WarmUpError`. The seconds are the wall time of the whole,
    the CPU seconds and counts the sums over the processes."""
    import threading

    start = time.perf_counter()
    outs: list[list[str]] = [[] for _ in parts]

    def read(i: int, proc: subprocess.Popen[str]) -> None:
        assert proc.stdout is not None
        for line in proc.stdout:
            kind, _, name = line.strip().partition(" ")
            if progress is not None and kind in ("start", "done") and name:
                progress(name, kind == "done")
            outs[i].append(line)

    with tempfile.TemporaryDirectory(prefix="bowlrec-warm-") as tmp:
        lock = os.path.join(tmp, "numba-cache-writes.lock")
        procs = [
            subprocess.Popen(
                [sys.executable, "-m", module, "--json", "--progress", "--cache-lock", lock, *p],
                stdout=subprocess.PIPE,
                text=True,
            )
            for p in parts
        ]
        readers = [threading.Thread(target=read, args=(i, p)) for i, p in enumerate(procs)]
        for reader in readers:
            reader.start()
        for proc, reader in zip(procs, readers, strict=True):
            proc.wait()
            reader.join()
    results = []
    for part, proc, out in zip(parts, procs, outs, strict=True):
        if proc.returncode != 0 or not out:
            raise WarmUpError(f"warming {' '.join(part)} failed (exit {proc.returncode})")
        results.append(json.loads(out[-1]))
    return WarmUp(
        names=tuple(n for r in results for n in r["names"]),
        seconds=time.perf_counter() - start,
        cpu_seconds=sum(r["cpu_seconds"] for r in results),
        compiled=sum(r["compiled"] for r in results),
        loaded=sum(r["loaded"] for r in results),
        jobs=len(parts),
    )


def main(
    argv: Sequence[str] | None = None,
    extra: Mapping[str, Callable[[], object]] | None = None,
    module: str = __name__,
) -> int:
    """The command (``bowlrec.testing.warm`` runs it with its ``extra`` kernels)."""
    parser = argparse.ArgumentParser(
        prog=f"python -m {module}",
        description="Load or compile bowlrec's numba kernels; prints one line.",
    )
    parser.add_argument("names", nargs="*", help="variants or groups (default: all)")
    parser.add_argument(
        "--jobs", type=int, default=1, help="compile in this many processes at once (default 1)"
    )
    parser.add_argument("--json", action="store_true", help="print the result as JSON")
    parser.add_argument("--cache-lock", help=argparse.SUPPRESS)  # a part of --jobs
    parser.add_argument("--progress", action="store_true", help=argparse.SUPPRESS)  # ditto
    args = parser.parse_args(argv)
    names = args.names or ["all"]
    try:
        expand(names, extra or {})
    except ValueError as err:
        parser.error(str(err))
    if args.cache_lock:
        _lock_cache_writes(args.cache_lock)
    report = None
    if args.progress:

        def report(name: str, done: bool) -> None:
            print("done" if done else "start", name, flush=True)

    result = warm_up(*names, extra=extra, jobs=args.jobs, module=module, progress=report)
    print(json.dumps(result.as_dict()) if args.json else result, flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main(module=__spec__.name))  # the processes of --jobs run it by name
