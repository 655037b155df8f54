"""Where the archive lives when no ``--archive`` is given.

Order: the ``BOWLREC_ARCHIVE`` environment variable; ``archive = "..."`` in the config file
(``$BOWLREC_CONFIG``, else ``$XDG_CONFIG_HOME/bowlrec/config.toml``, else
``~/.config/bowlrec/config.toml``); the embedded default ``$XDG_DATA_HOME/bowlrec/archive``
(else ``~/.local/share/bowlrec/archive``).

The same config file may name a Dask scheduler (``scheduler = "tcp://HOST:PORT"``) that
``bowlrec batch`` and ``bowlrec serve`` use when neither ``--scheduler`` nor
``$BOWLREC_SCHEDULER`` is given.
"""

from __future__ import annotations

import os
import tomllib
from pathlib import Path

from bowlrec.errors import ConfigError

__all__ = ["ENV_ARCHIVE", "config_path", "config_value", "default_archive_path"]

ENV_ARCHIVE = "BOWLREC_ARCHIVE"
ENV_CONFIG = "BOWLREC_CONFIG"


def config_path() -> Path:
    """The config file bowlrec reads (it need not exist)."""
    if os.environ.get(ENV_CONFIG):
        return Path(os.environ[ENV_CONFIG]).expanduser()
    base = os.environ.get("XDG_CONFIG_HOME") or str(Path.home() / ".config")
    return Path(base) / "bowlrec" / "config.toml"


def config_value(key: str) -> str | None:
    """A top-level string entry of the config file (None when the file or key is missing);
    :class:`~bowlrec.errors.ConfigError` when the file is not valid TOML."""
    cfg = config_path()
    if not cfg.is_file():
        return None
    try:
        data = tomllib.loads(cfg.read_text())
    except tomllib.TOMLDecodeError as err:
        raise ConfigError(f"{cfg}: not valid TOML ({err})") from None
    value = data.get(key)
    return None if value is None else str(value)


def default_archive_path() -> tuple[Path, str]:
    """(path, where it came from: "environment", "config <file>" or "default")."""
    if os.environ.get(ENV_ARCHIVE):
        return Path(os.environ[ENV_ARCHIVE]).expanduser(), f"${ENV_ARCHIVE}"
    configured = config_value("archive")
    if configured is not None:
        return Path(configured).expanduser(), f"config {config_path()}"
    base = os.environ.get("XDG_DATA_HOME") or str(Path.home() / ".local" / "share")
    return Path(base) / "bowlrec" / "archive", "default"
