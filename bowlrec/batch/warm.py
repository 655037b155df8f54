"""Imported by a batch's fork server: loads the compiled kernels a worker runs (the ``batch``
group of :func:`bowlrec.core.warm.warm_up`: the many-delivery kernel and the integrator) from the
on-disk cache once, so every worker forked from it starts ready (no per-worker import or cache
load).

It first makes the fork server exit as soon as the process that started it is gone, and its
workers with it (:mod:`bowlrec.batch.lifeline`)."""

from __future__ import annotations

from bowlrec.core.warm import warm_up

from .lifeline import guard_fork_server

guard_fork_server()


def _warm() -> None:
    warm_up("batch")


_warm()
