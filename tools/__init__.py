"""Developers' scripts for the repository (not part of the installed package): the generated
blocks of README.md and docs/*.md (``tools.readme_blocks``) and the Table III block
(``python -m tools.update_table3``). Import them from the repository's root."""
