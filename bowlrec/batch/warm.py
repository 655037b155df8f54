"""Imported by a batch's fork server: loads the compiled kernels from the on-disk cache once, so
every worker forked from it starts ready (no per-worker import or cache load).

It first makes the fork server exit as soon as the process that started it is gone, and its
workers with it (:mod:`bowlrec.batch.lifeline`)."""

from __future__ import annotations

from bowlrec.core.batch import pack_plans, run_batch
from bowlrec.core.codes import RECORD_SUMMARY
from bowlrec.core.solver import solve
from bowlrec.spec import Scene

from .lifeline import guard_fork_server

guard_fork_server()


def _warm() -> None:

    plan = Scene.model_validate({"options": {"record": "summary"}}).resolve()
    assert plan.record_mode == RECORD_SUMMARY
    run_batch(pack_plans([plan]), parallel=False)
    solve(Scene.model_validate({"options": {"record": "steps", "max_time_s": 0.01}}).resolve())


_warm()
