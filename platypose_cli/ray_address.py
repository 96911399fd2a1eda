"""``--ray-address``: checked before Ray is asked to connect, with a deadline.

Ray's own connection to a cluster that is not there retries for minutes in native code that Ctrl-C does not reach,
and an address that is not one ends in a ValueError. Here the address is parsed, its host is reached over TCP, and
it must answer the HTTP/2 greeting every gRPC server (a Ray cluster's GCS, Ray Client) sends, all within a deadline;
anything else is one line naming the option.
"""

from __future__ import annotations

import os
import socket
import time

from platypose.lifting.errors import InputError

CONNECT_TIMEOUT_S = 10.0
_PREFACE = b"PRI * HTTP/2.0\r\n\r\nSM\r\n\r\n" + b"\x00\x00\x00\x04\x00\x00\x00\x00\x00"  # + an empty SETTINGS frame
_SETTINGS = 0x04


def host_port(address: str) -> tuple[str, int]:
    """(host, port) of ``HOST:PORT`` or ``ray://HOST:PORT``; InputError for anything else."""
    rest = address.removeprefix("ray://")
    host, _, port = rest.rpartition(":")
    host = host.strip("[]")
    if (
        not host
        or not (port.isascii() and port.isdigit())
        or not 0 < int(port) < 65536
        or any(c.isspace() for c in host)
    ):
        raise InputError(f"--ray-address {address}: not an address (expected auto, HOST:PORT or ray://HOST:PORT)")
    return host, int(port)


def _greeting(sock: socket.socket, deadline: float) -> bytes:
    """The first 9 bytes (an HTTP/2 frame header) the server sends after our preface, or fewer at the deadline."""
    sock.sendall(_PREFACE)
    received = b""
    while len(received) < 9 and time.monotonic() < deadline:
        sock.settimeout(max(deadline - time.monotonic(), 0.01))
        try:
            chunk = sock.recv(9 - len(received))
        except TimeoutError:
            break
        if not chunk:
            break
        received += chunk
    return received


def check_ray_address(address: str, timeout_s: float = CONNECT_TIMEOUT_S) -> None:
    """InputError unless ``address`` (``auto`` reads ``RAY_ADDRESS``) is a reachable gRPC server, within
    ``timeout_s``. ``auto`` without ``RAY_ADDRESS`` is left to Ray, which looks for a cluster on this machine."""
    shown = address
    if address == "auto":
        address = os.environ.get("RAY_ADDRESS", "")
        if not address or address == "auto":
            return
        shown = f"auto (RAY_ADDRESS={address})"
    host, port = host_port(address)
    deadline = time.monotonic() + timeout_s
    try:
        with socket.create_connection((host, port), timeout=timeout_s) as sock:
            header = _greeting(sock, deadline)
    except OSError as err:
        reason = err.strerror or type(err).__name__
        raise InputError(f"--ray-address {shown}: nothing answers at {host}:{port} ({reason})") from None
    if len(header) < 9 or header[3] != _SETTINGS:
        raise InputError(
            f"--ray-address {shown}: {host}:{port} answers but not as a Ray cluster (no gRPC reply in {timeout_s:g} s)"
        )
