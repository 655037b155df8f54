"""Where the archive lives when no ``--archive`` is given.

Order: the ``BOWLREC_ARCHIVE`` environment variable; ``archive = "..."`` in the config file
(``$BOWLREC_CONFIG``, else ``$XDG_CONFIG_HOME/bowlrec/config.toml``, else
``~/.config/bowlrec/config.toml``); the embedded default ``$XDG_DATA_HOME/bowlrec/archive``
(else ``~/.local/share/bowlrec/archive``).
"""

from __future__ import annotations

import os
import tomllib
from pathlib import Path

__all__ = ["ENV_ARCHIVE", "config_path", "default_archive_path"]

ENV_ARCHIVE = "BOWLREC_ARCHIVE"
ENV_CONFIG = "BOWLREC_CONFIG"


def config_path() -> Path:
    """The config file bowlrec reads (it need not exist)."""
    if os.environ.get(ENV_CONFIG):
        return Path(os.environ[ENV_CONFIG]).expanduser()
    base = os.environ.get("XDG_CONFIG_HOME") or str(Path.home() / ".config")
    return Path(base) / "bowlrec" / "config.toml"


def default_archive_path() -> tuple[Path, str]:
    """(path, where it came from: "environment", "config <file>" or "default")."""
    if os.environ.get(ENV_ARCHIVE):
        return Path(os.environ[ENV_ARCHIVE]).expanduser(), f"${ENV_ARCHIVE}"
    cfg = config_path()
    if cfg.is_file():
        try:
            data = tomllib.loads(cfg.read_text())
        except tomllib.TOMLDecodeError as err:
            raise ValueError(f"{cfg}: not valid TOML ({err})") from None
        if "archive" in data:
            return Path(str(data["archive"])).expanduser(), f"config {cfg}"
    base = os.environ.get("XDG_DATA_HOME") or str(Path.home() / ".local" / "share")
    return Path(base) / "bowlrec" / "archive", "default"
