"""Every server the package starts listens on loopback unless the user asks for more.

The bound addresses are read from the operating system (psutil's view of the listening
sockets of this process and the processes it started), not from the libraries' settings.
"""

from __future__ import annotations

import ast
import ipaddress
import logging
from pathlib import Path

import psutil
import pytest

from emonav_drake.diagrams.meshcat_viewing import is_loopback_host, make_meshcat

PACKAGE = Path(__file__).resolve().parents[1] / "emonav_drake"


def _listening(pids: set[int]) -> list[tuple[str, int, int]]:
    """(address, port, pid) of every TCP socket in LISTEN state owned by `pids`."""
    out = []
    for c in psutil.net_connections(kind="tcp"):
        if c.status == psutil.CONN_LISTEN and c.pid in pids:
            out.append((c.laddr.ip, c.laddr.port, c.pid))
    return out


def _loopback(ip: str) -> bool:
    addr = ipaddress.ip_address(ip)
    mapped = getattr(addr, "ipv4_mapped", None)  # [::ffff:127.0.0.1]
    return (mapped or addr).is_loopback


def _family() -> set[int]:
    me = psutil.Process()
    return {me.pid} | {p.pid for p in me.children(recursive=True)}


def test_meshcat_listens_on_loopback_by_default():
    meshcat = make_meshcat(live=False)
    socks = [s for s in _listening(_family()) if s[1] == meshcat.port()]
    assert socks, "the Meshcat port is not listening"
    assert all(_loopback(ip) for ip, _, _ in socks), socks


def test_meshcat_on_every_interface_only_when_asked_and_with_a_warning(caplog):
    with caplog.at_level(logging.WARNING):
        meshcat = make_meshcat(live=False, host="*")
    socks = [s for s in _listening(_family()) if s[1] == meshcat.port()]
    del meshcat  # its server closes
    assert socks and not any(_loopback(ip) for ip, _, _ in socks), socks
    assert "every interface" in caplog.text and "no authentication" in caplog.text


def test_loopback_host_names():
    assert is_loopback_host("localhost") and is_loopback_host("127.0.0.1")
    assert is_loopback_host("::1") and is_loopback_host("[::1]")
    assert not is_loopback_host("*") and not is_loopback_host("0.0.0.0")
    assert not is_loopback_host("192.0.2.7") and not is_loopback_host("example.org")


@pytest.mark.slow
def test_every_meshcat_the_package_starts_goes_through_make_meshcat():
    """No module constructs `Meshcat(...)` itself: the one constructor picks loopback."""
    offenders = []
    for path in PACKAGE.rglob("*.py"):
        tree = ast.parse(path.read_text())
        for node in ast.walk(tree):
            if (
                isinstance(node, ast.Call)
                and isinstance(node.func, ast.Name)
                and node.func.id in ("Meshcat", "StartMeshcat")
            ):
                offenders.append(f"{path.relative_to(PACKAGE)}:{node.lineno}")
    allowed = {"diagrams/meshcat_viewing.py"}
    assert [o for o in offenders if o.split(":")[0] not in allowed] == []


@pytest.mark.slow
def test_local_ray_listens_on_loopback_only():
    pytest.importorskip("ray")
    from emonav_drake.parallel import init_ray, ray_node_address

    before = set(_listening(_family()))  # e.g. a Meshcat of an earlier test
    ray = init_ray(1, None)
    try:

        @ray.remote
        def one() -> int:
            return 1

        assert ray.get(one.remote()) == 1  # a worker is up, with its own server
        socks = [s for s in _listening(_family()) if s not in before]
        names = {psutil.Process(pid).name() for _, _, pid in socks}
        assert {"gcs_server", "raylet"} <= names, names
        assert all(_loopback(ip) for ip, _, _ in socks), socks
        assert _loopback(ray_node_address(ray))
    finally:
        ray.shutdown()


def _tiny_config(tmp_path: Path) -> str:
    path = tmp_path / "tiny.yaml"
    path.write_text("episode: {max_steps: 2}\n")
    return str(path)


@pytest.mark.slow
def test_sim_meshcat_host_opens_only_on_request_and_warns(tmp_path, caplog):
    from emonav_drake.cli import main

    base = ["sim", "--seed", "3", "--config", _tiny_config(tmp_path), "--meshcat", "--no-wait"]
    with caplog.at_level(logging.WARNING):
        assert main(base) == 0
    assert "no authentication" not in caplog.text
    caplog.clear()
    with caplog.at_level(logging.WARNING):
        assert main([*base, "--meshcat-host", "*"]) == 0
    assert "every interface" in caplog.text


def test_meshcat_host_without_meshcat_is_refused(tmp_path, capsys):
    from emonav_drake.cli import main

    argv = ["sim", "--config", _tiny_config(tmp_path), "--meshcat-host", "*"]
    assert main(argv) == 2
    assert "--meshcat-host is used with --meshcat only" in capsys.readouterr().err
    assert main(["walk", "--seconds", "0.1", "--meshcat-host", "0.0.0.0"]) == 2
    assert "--meshcat-host is used with --meshcat only" in capsys.readouterr().err
