"""Child process for tests/test_pipeline_faults.py: ``bowlrec serve`` whose jobs run in small
chunks.

Usage: python pipeline_fault_child.py CHUNK --archive DIR --port PORT [...]  (the serve
command's options after CHUNK)

``bowlrec serve`` has no chunk-size option: a job's chunks take the batch engine's default size
(``bowlrec.batch.runner.SUMMARY_CHUNK`` runs at most for a summary-only job). This sets that
constant to CHUNK first, so that a job of a few thousand runs seals many segments and a kill
lands between, or in the middle of, segment writes.
"""

from __future__ import annotations

import sys

import bowlrec.batch.runner as runner
from bowlrec.cli import app
from bowlrec.cli import serve as _serve  # noqa: F401  (registers the command)

if __name__ == "__main__":
    runner.SUMMARY_CHUNK = int(sys.argv[1])
    sys.argv = ["bowlrec", "serve", *sys.argv[2:]]
    app()
