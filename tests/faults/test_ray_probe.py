"""The ``--ray-address`` probe asks Ray's own gRPC call: an HTTP/2 or gRPC server that is not Ray is refused, and
a local address is also probed where Ray really dials it (this machine's address in place of 127.0.0.1). The audit
cases (marker ``audit``) give addresses that are no cluster to the real CLI (:mod:`audit_watch`)."""

from __future__ import annotations

import socket
import threading
from pathlib import Path

import pytest
from audit_watch import LIFT, check

from platypose.cli.runs import ray_address
from platypose.cli.runs.ray_address import check_ray_address
from platypose.lifting.errors import InputError


def frame(kind: int, flags: int, stream: int, payload: bytes = b"") -> bytes:
    return len(payload).to_bytes(3, "big") + bytes([kind, flags]) + stream.to_bytes(4, "big") + payload


SETTINGS = frame(0x4, 0, 0)
STATUS_200 = frame(0x1, 0x4, 1, b"\x88")  # HPACK static entry 8: ":status 200"
HTML = b"<html><body>It works!</body></html>"
CLUSTER_ID = bytes([0x12, 28]) + b"c" * 28  # GetClusterIdReply.cluster_id
SSH_GREETING = b"SSH-2.0-OpenSSH_9.6\r\n"  # a server that is not Ray
TRAILERS = frame(0x1, 0x5, 1, b"\x00\x0bgrpc-status\x010")


def serve(reply: bytes, host: str = "127.0.0.1") -> tuple[int, threading.Event]:
    """A server on ``host`` answering each connection's first bytes with ``reply`` (then holding it open a moment)."""
    listener = socket.create_server((host, 0))
    listener.settimeout(0.2)
    stop = threading.Event()

    def run() -> None:
        while not stop.is_set():
            try:
                conn, _ = listener.accept()
            except TimeoutError:
                continue
            with conn:
                conn.recv(4096)
                conn.sendall(reply)
                conn.settimeout(1.0)
                try:
                    conn.recv(4096)
                except OSError:
                    pass

    threading.Thread(target=run, daemon=True).start()
    return listener.getsockname()[1], stop


@pytest.mark.parametrize(
    "reply",
    [
        SETTINGS,  # an HTTP/2 greeting and nothing more
        SETTINGS + STATUS_200 + frame(0x0, 0x1, 1, HTML),  # a web server speaking HTTP/2
        SETTINGS + frame(0x1, 0x5, 1, b"\x88\x00\x0bgrpc-status\x0212"),  # gRPC: no such call (UNIMPLEMENTED)
        SETTINGS + frame(0x7, 0, 0, bytes(8)),  # GOAWAY
    ],
    ids=["greeting-only", "web-server", "other-grpc", "goaway"],
)
@pytest.mark.parametrize("scheme", ["", "ray://"])
def test_an_http2_server_that_is_not_ray_is_refused(reply: bytes, scheme: str, monkeypatch) -> None:
    monkeypatch.delenv("RAY_AUTH_MODE", raising=False)
    port, stop = serve(reply)
    call = "ClusterInfo" if scheme else "GetClusterId"
    try:
        with pytest.raises(
            InputError, match=f"127.0.0.1:{port} answers but not as a Ray cluster .*Ray's {call} in 2 s"
        ):
            check_ray_address(f"{scheme}127.0.0.1:{port}", timeout_s=2)
    finally:
        stop.set()


def test_a_gcs_reply_passes_and_ray_s_dialled_address_is_probed_too(monkeypatch) -> None:
    ray_like = SETTINGS + STATUS_200 + frame(0x0, 0, 1, b"\x00" + len(CLUSTER_ID).to_bytes(4, "big") + CLUSTER_ID)
    port, stop = serve(ray_like + TRAILERS, host="127.0.0.1")
    try:
        monkeypatch.setattr(ray_address, "dialled_host", lambda host: host)
        check_ray_address(f"127.0.0.1:{port}", timeout_s=2)
        monkeypatch.setattr(ray_address, "dialled_host", lambda host: "127.0.0.2")  # bound to 127.0.0.1 only
        expected = (
            f"Ray dials 127.0.0.2:{port} (this machine's address, in place of 127.0.0.1) and no Ray cluster answers "
            "there: a port-forward to 127.0.0.1 only?"
        )
        with pytest.raises(InputError, match=expected.replace("(", r"\(").replace(")", r"\)").replace(".", r"\.")):
            check_ray_address(f"127.0.0.1:{port}", timeout_s=2)
    finally:
        stop.set()


def test_ray_dials_this_machine_for_a_local_host() -> None:
    pytest.importorskip("ray")
    from ray._private.services import get_node_ip_address

    assert ray_address.dialled_host("127.0.0.1") == get_node_ip_address()
    assert ray_address.dialled_host("head.example") == "head.example"


def _server(reply: bytes):
    """A TCP server on a free local port that answers every connection with ``reply``; (port, stop)."""
    import socket
    import threading

    listener = socket.create_server(("127.0.0.1", 0))
    listener.settimeout(0.2)
    stop = threading.Event()

    def serve() -> None:
        while not stop.is_set():
            try:
                conn, _ = listener.accept()
            except TimeoutError:
                continue
            conn.recv(64)
            conn.sendall(reply)
            conn.close()

    threading.Thread(target=serve, daemon=True).start()
    return listener.getsockname()[1], stop


def _closed_port() -> int:
    import socket

    with socket.create_server(("127.0.0.1", 0)) as probe:
        return probe.getsockname()[1]


def test_ray_address_is_checked_with_a_deadline(run_cli, batch_folder, prior_file, tmp_path) -> None:
    import time

    for bad in ("nonsense", "host:", "ray://:10001", "a b:1", "h:70000"):
        with pytest.raises(InputError, match="not an address"):
            check_ray_address(bad)
    port, stop = _server(SSH_GREETING)
    with pytest.raises(InputError, match="answers but not as a Ray cluster"):
        check_ray_address(f"127.0.0.1:{port}", timeout_s=2)
    stop.set()
    started = time.monotonic()
    for address in (f"127.0.0.1:{_closed_port()}", "nonsense"):
        code, _, err = run_cli(
            "lift", str(batch_folder / "good.mp4"), "--prior", prior_file, "--out", str(tmp_path),
            "--executor", "ray", "--ray-address", address, "--quiet",
        )  # fmt: skip
        assert code == 2 and err.startswith("error: --ray-address") and len(err.strip().splitlines()) == 1, err
    assert time.monotonic() - started < 30


@pytest.mark.audit
@pytest.mark.parametrize(
    ("address", "needle"),
    [
        (lambda: f"127.0.0.1:{_closed_port()}", "nothing answers"),
        (lambda: "nonsense", "not an address"),
        (lambda: f"ray://127.0.0.1:{_closed_port()}", "nothing answers"),
        (lambda: f"127.0.0.1:{_server(SSH_GREETING)[0]}", "not as a Ray cluster"),
        (lambda: "no-such-host.invalid:6379", "nothing answers"),
        (lambda: "127.0.0.1:0", "not an address"),
    ],
    ids=["closed-port", "nonsense", "ray-client-closed", "ssh-server", "unresolvable", "port-0"],
)
def test_ray_addresses_that_are_no_cluster(batch_folder, tmp_path: Path, address, needle: str) -> None:
    args = ["lift", batch_folder / "good.mp4", "--executor", "ray", "--ray-address", address(), *LIFT]
    check(tmp_path, args, "error", ("--ray-address", needle), timeout=90)
