"""``--ray-address``: checked before Ray is asked to connect, with a deadline.

Ray's own connection to a cluster that is not there retries for minutes in native code that Ctrl-C does not reach,
and an address that is not one ends in a ValueError. Here the address is parsed, its host is reached over TCP, and
it must answer one of Ray's own gRPC calls, all within a deadline; anything else is one line naming the option:

- a cluster's GCS (``HOST:PORT``) is asked ``ray.rpc.NodeInfoGcsService/GetClusterId`` and must reply with a
  cluster id (any other HTTP/2 or gRPC server has no such call); a cluster with token authentication refuses a
  probe without the token, so with ``RAY_AUTH_MODE=token`` a gRPC refusal is left to Ray to explain;
- Ray Client (``ray://HOST:PORT``) is asked ``ray.rpc.RayletDriver/ClusterInfo`` and must reply with a message;
- Ray replaces a local host (``127.0.0.1``, ``localhost``) by this machine's own address before it dials a GCS, so
  that address is probed too: a head reached through a port-forward on 127.0.0.1 would be retried for ever.

The call is written by hand (HTTP/2 frames, HPACK literals, gRPC's 5-byte message prefix), so no gRPC library is
needed for the check.
"""

from __future__ import annotations

import os
import socket
import time

from platypose.lifting.errors import InputError

CONNECT_TIMEOUT_S = 10.0
_PREFACE = b"PRI * HTTP/2.0\r\n\r\nSM\r\n\r\n"
_DATA, _HEADERS, _RST_STREAM, _SETTINGS, _PING, _GOAWAY = 0x0, 0x1, 0x3, 0x4, 0x6, 0x7
_END_STREAM, _END_HEADERS, _ACK = 0x1, 0x4, 0x1
_GCS_CALL = "/ray.rpc.NodeInfoGcsService/GetClusterId"
_CLIENT_CALL = "/ray.rpc.RayletDriver/ClusterInfo"
_LOCAL_HOSTS = ("localhost", "::1")


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


def _frame(kind: int, flags: int, stream: int, payload: bytes = b"") -> bytes:
    return len(payload).to_bytes(3, "big") + bytes([kind, flags]) + stream.to_bytes(4, "big") + payload


def _hpack_string(text: str) -> bytes:
    """An HPACK string literal (no Huffman coding): its length as a 7-bit-prefix integer, then its bytes."""
    data, length, out = text.encode(), len(text.encode()), bytearray()
    if length < 127:
        out.append(length)
    else:
        out.append(127)
        length -= 127
        while length >= 128:
            out.append(length % 128 + 128)
            length //= 128
        out.append(length)
    return bytes(out) + data


def _request(host: str, port: int, path: str) -> bytes:
    """The HTTP/2 preface, our SETTINGS, and a unary gRPC call of ``path`` with an empty message on stream 1."""
    headers = [
        (":method", "POST"),
        (":scheme", "http"),
        (":path", path),
        (":authority", f"{host}:{port}"),
        ("content-type", "application/grpc"),
        ("te", "trailers"),
    ]
    block = b"".join(b"\x00" + _hpack_string(name) + _hpack_string(value) for name, value in headers)
    message = b"\x00" + (0).to_bytes(4, "big")  # not compressed, 0 bytes: an empty request
    return (
        _PREFACE
        + _frame(_SETTINGS, 0, 0)
        + _frame(_HEADERS, _END_HEADERS, 1, block)
        + _frame(_DATA, _END_STREAM, 1, message)
    )


def _reply(sock: socket.socket, deadline: float) -> tuple[bool, bytes]:
    """(whether stream 1 got a response, the DATA it carried) read until the stream ends, the connection closes or
    the deadline passes; the server's SETTINGS and PINGs are acknowledged as HTTP/2 asks."""
    buffer, data, answered = b"", b"", False
    while time.monotonic() < deadline:
        while len(buffer) >= 9 and len(buffer) >= 9 + int.from_bytes(buffer[:3], "big"):
            length, kind, flags = int.from_bytes(buffer[:3], "big"), buffer[3], buffer[4]
            stream, payload, buffer = (
                int.from_bytes(buffer[5:9], "big") & 0x7FFFFFFF,
                buffer[9 : 9 + length],
                buffer[9 + length :],
            )
            if kind == _SETTINGS and not flags & _ACK:
                sock.sendall(_frame(_SETTINGS, _ACK, 0))
            elif kind == _PING and not flags & _ACK:
                sock.sendall(_frame(_PING, _ACK, 0, payload))
            elif kind in (_GOAWAY, _RST_STREAM) and stream in (0, 1):
                return answered, data
            elif stream == 1 and kind in (_HEADERS, _DATA):
                answered = True
                data += payload if kind == _DATA else b""
                if flags & _END_STREAM:
                    return answered, data
        sock.settimeout(max(deadline - time.monotonic(), 0.01))
        try:
            chunk = sock.recv(65536)
        except TimeoutError:
            break
        if not chunk:
            break
        buffer += chunk
    return answered, data


def _grpc_message(data: bytes) -> bytes | None:
    """The one message of a unary gRPC reply's DATA (1 byte not compressed, 4 bytes length, the message)."""
    if len(data) < 5 or data[0] != 0 or int.from_bytes(data[1:5], "big") != len(data) - 5:
        return None
    return data[5:]


def _cluster_id(message: bytes) -> bytes:
    """Field 2 (``cluster_id``) of a GetClusterIdReply; empty when absent; ValueError for malformed protobuf."""
    found, at = b"", 0
    while at < len(message):
        key, at = _varint(message, at)
        number, wire = key >> 3, key & 7
        if wire == 0:
            _, at = _varint(message, at)
        elif wire == 2:
            length, at = _varint(message, at)
            if at + length > len(message):
                raise ValueError("truncated field")
            if number == 2:
                found = message[at : at + length]
            at += length
        else:
            raise ValueError(f"wire type {wire}")
    return found


def _varint(data: bytes, at: int) -> tuple[int, int]:
    value, shift = 0, 0
    while at < len(data) and shift < 64:
        byte = data[at]
        value |= (byte & 0x7F) << shift
        at, shift = at + 1, shift + 7
        if not byte & 0x80:
            return value, at
    raise ValueError("bad varint")


def _is_ray(host: str, port: int, client: bool, deadline: float, shown: str) -> bool:
    """Whether ``host:port`` answers Ray's probe call (see the module); InputError when nothing answers at all."""
    try:
        sock = socket.create_connection((host, port), timeout=max(deadline - time.monotonic(), 0.01))
    except OSError as err:
        reason = err.strerror or type(err).__name__
        raise InputError(f"--ray-address {shown}: nothing answers at {host}:{port} ({reason})") from None
    with sock:
        try:
            sock.sendall(_request(host, port, _CLIENT_CALL if client else _GCS_CALL))
            answered, data = _reply(sock, deadline)
        except OSError:  # connected, then reset: a server, but not one that takes the call
            return False
    message = _grpc_message(data)
    if client:
        return message is not None
    try:
        if message is not None and _cluster_id(message):
            return True
    except ValueError:
        return False
    return answered and message is None and not data and os.environ.get("RAY_AUTH_MODE") == "token"


def dialled_host(host: str) -> str:
    """The host Ray dials for a GCS at ``host``: this machine's address in place of a local one (Ray's own rule,
    taken from Ray where it is installed)."""
    if not (host in _LOCAL_HOSTS or host.startswith("127.")):
        return host
    try:
        from ray._private.services import get_node_ip_address

        return str(get_node_ip_address())
    except Exception:  # Ray missing or changed: nothing to add to the probe
        return host


def check_ray_address(address: str, timeout_s: float = CONNECT_TIMEOUT_S) -> None:
    """InputError unless ``address`` (``auto`` reads ``RAY_ADDRESS``) answers as a Ray cluster (a GCS, or Ray Client
    for ``ray://``) within ``timeout_s``, at the host Ray will dial too. ``auto`` without ``RAY_ADDRESS`` is left to
    Ray, which looks for a cluster on this machine."""
    shown = address
    if address == "auto":
        address = os.environ.get("RAY_ADDRESS", "")
        if not address or address == "auto":
            return
        shown = f"auto (RAY_ADDRESS={address})"
    host, port = host_port(address)
    client = address.startswith("ray://")
    deadline = time.monotonic() + timeout_s
    if not _is_ray(host, port, client, deadline, shown):
        raise InputError(
            f"--ray-address {shown}: {host}:{port} answers but not as a Ray cluster (no reply to Ray's "
            f"{(_CLIENT_CALL if client else _GCS_CALL).rsplit('/', 1)[1]} in {timeout_s:g} s; a cluster with token "
            "authentication also needs RAY_AUTH_MODE=token here, docs/ray.md)"
        )
    dialled = host if client else dialled_host(host)
    if dialled != host:
        try:
            reached = _is_ray(dialled, port, False, time.monotonic() + timeout_s, shown)
        except InputError:
            reached = False
        if not reached:
            raise InputError(
                f"--ray-address {shown}: Ray dials {dialled}:{port} (this machine's address, in place of {host}) "
                f"and no Ray cluster answers there: a port-forward to {host} only? Give the head's own address, or "
                "Ray Client (ray://HOST:10001)"
            )
