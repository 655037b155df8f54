"""``python -m bowlrec.cli``: the same as the ``bowlrec`` command."""

from . import main

main()
