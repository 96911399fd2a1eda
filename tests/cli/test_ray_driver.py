"""What connecting to Ray does to our process: with ``-q`` a Ray cluster started by the lift prints no Ray warnings
(Ray's token-authentication warning once came through ``-q``) while the lift's own flags still print, and Ray's
driver leaves our SIGTERM handler in place."""

from __future__ import annotations

import os
import subprocess
import sys


def test_a_quiet_ray_lift_prints_no_ray_warning(batch_folder, prior_file, tmp_path) -> None:
    env = {k: v for k, v in os.environ.items() if not k.startswith("RAY_")}  # Ray's own defaults, no token set
    args = ["lift", str(batch_folder / "good.mp4"), "--prior", str(prior_file), "--samples", "2", "--threads", "1"]
    args += ["--formats", "npz", "--executor", "ray", "--out", str(tmp_path / "out"), "-q"]
    done = subprocess.run([sys.executable, "-m", "platypose", *args], capture_output=True, text=True, env=env)
    assert done.returncode == 0, done.stderr
    assert "Token authentication" not in done.stderr and "WARNING" not in done.stderr, done.stderr


def test_connecting_to_ray_keeps_our_sigterm_handler(monkeypatch) -> None:
    import signal
    import types

    from platypose.cli.runs import ray as lift_ray

    def fake_init(**_):  # as Ray's driver does: its own SIGTERM handler
        signal.signal(signal.SIGTERM, lambda *a: sys.exit(1))

    fake = types.SimpleNamespace(is_initialized=lambda: False, init=fake_init, shutdown=lambda: None)
    monkeypatch.setattr(lift_ray, "import_ray", lambda: fake)
    monkeypatch.setattr(lift_ray, "check_ray_address", lambda address: None)
    ours = signal.signal(signal.SIGTERM, signal.default_int_handler)
    try:
        with lift_ray.connected(lift_ray.RayOptions(), quiet=True):
            assert signal.getsignal(signal.SIGTERM) is signal.default_int_handler
    finally:
        signal.signal(signal.SIGTERM, ours)
