"""Names and numbers of the service's access policy that the command line needs too, without
importing the web stack (``bowlrec --help`` stays fast): the token's minimum length, the
default body limit, and host names (``Host`` headers, ``--host``, ``--allowed-host``)."""

from __future__ import annotations

import ipaddress

__all__ = ["DEFAULT_MAX_BODY_BYTES", "MIN_TOKEN_LENGTH", "host_name", "is_loopback_name"]

#: the shortest token ``serve`` accepts on a non-loopback host
MIN_TOKEN_LENGTH = 32
#: 32 MiB: a 100,000-scene job as explicit scenes (about 3.4 MB) fits ten times over
DEFAULT_MAX_BODY_BYTES = 32 * 1024 * 1024


def host_name(value: str) -> str | None:
    """The host name of a ``Host`` header or an allow-list entry, normalised: lower case, no
    port, no trailing dot, IPv6 without brackets and in compressed form. None if malformed."""
    value = value.strip().lower()
    if not value:
        return None
    if value.startswith("["):
        end = value.find("]")
        if end < 0:
            return None
        name, rest = value[1:end], value[end + 1 :]
        if rest and not (rest.startswith(":") and rest[1:].isdigit()):
            return None
        try:
            return str(ipaddress.IPv6Address(name))
        except ValueError:
            return None
    if value.count(":") > 1:  # a bare IPv6 address (an allow-list entry may be written so)
        try:
            return str(ipaddress.IPv6Address(value))
        except ValueError:
            return None
    name, sep, port = value.partition(":")
    if sep and not port.isdigit():
        return None
    name = name.rstrip(".")
    if not name or any(c.isspace() or c in "/\\@?#" for c in name):
        return None
    return name


def is_loopback_name(name: str) -> bool:
    """``localhost``, 127.0.0.0/8 or ::1 (a name as :func:`host_name` returns it)."""
    if name == "localhost":
        return True
    try:
        return ipaddress.ip_address(name).is_loopback
    except ValueError:
        return False
