"""Rewrite the Table III block of docs/validation.md from a fresh simulation of the paper's 18
cases (``bowlrec.paper_table``); ``tests/test_cli.py`` checks that the block is the computed one.

    python -m tools.update_table3 [--check]

``--check`` changes nothing and exits 1 when the block differs from the computed table.
"""

from __future__ import annotations

import argparse

from bowlrec.paper_table import markdown_table, run_paper_cases

from .readme_blocks import block_path, read_block, replace_block

BLOCK = "table3"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--check", action="store_true", help="only compare; exit 1 when it differs")
    args = ap.parse_args(argv)
    table = markdown_table(run_paper_cases())
    path = block_path(BLOCK)
    if args.check:
        same = read_block(path, BLOCK) == table
        print(f"{path}: {'up to date' if same else 'differs from the computed table'}")
        return 0 if same else 1
    changed = replace_block(path, BLOCK, table)
    print(f"{path}: {'updated' if changed else 'already up to date'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
