"""Child process for the service tests: ``bowlrec serve`` with the given arguments.

Usage: python service_child.py --archive DIR --port PORT [...]  (the serve command's options)

The serve command is registered here by importing its module, so this works whether or not
``bowlrec.cli`` registers it.
"""

from __future__ import annotations

import sys

from bowlrec.cli import app
from bowlrec.cli import serve as _serve  # noqa: F401  (registers the command)

if __name__ == "__main__":
    sys.argv = ["bowlrec", "serve", *sys.argv[1:]]
    app()
