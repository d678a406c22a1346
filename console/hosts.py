"""Host names and addresses: which ones only this machine can reach, and whether one can be listened on (the
console's and the agent door's checks)."""

from __future__ import annotations

import ipaddress
import socket

LOOPBACK_NAMES = ("localhost",)


def is_loopback(host: str) -> bool:
    """Whether ``host`` only accepts connections from this machine."""
    if host in LOOPBACK_NAMES:
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


def check_listenable(host: str) -> None:
    """Raise ``OSError`` naming ``host`` if no socket can listen there (viser would wait forever)."""
    try:
        infos = socket.getaddrinfo(host, None, type=socket.SOCK_STREAM)
    except socket.gaierror as exc:
        raise OSError(f"cannot listen on {host!r}: unknown host ({exc})") from None
    family, _, _, _, addr = infos[0]
    with socket.socket(family, socket.SOCK_STREAM) as sock:
        try:
            sock.bind((addr[0], 0))
        except OSError as exc:
            raise OSError(f"cannot listen on {host!r}: {exc.strerror or exc}; is it an address of this machine?") from None
