"""Starting or joining Ray, closed to the network unless a cluster is asked for.

`init_ray(workers, address)` is the one place the package starts Ray (benchmarks, trace
collection, SAC's parallel environments).

* No address (a local run, `--workers N`): Ray starts on this machine with `workers`
  CPUs, and every server it starts — the GCS, the raylet, the object manager, each
  worker's and the driver's gRPC port, the runtime-env agent — listens on the loopback
  interface only. Ray has no public switch for that: on Linux it binds its servers to the
  node's IP, which it takes from the interface that routes outwards (127.0.0.1 given as
  `_node_ip_address` is even turned back into that IP). Its macOS/Windows mode, selected
  by `RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER=0`, takes the loopback address as the node's IP
  instead; the servers then bind to 127.0.0.1. The variable is read when `ray` is first
  imported and inherited by every process Ray starts, so it is set here before the import
  (and the constant it sets is written too, should `ray` have been imported earlier); the
  node's address is checked after the start: a local Ray not on loopback is refused, never
  silently exposed.
* With an address (`--ray-address auto|HOST:PORT`): the driver joins a cluster started
  with `ray start`; the cluster's own `ray start` flags decide what listens where
  (`docs/reliability.md`, "Network exposure").

In both cases the dashboard is off, usage statistics are off, and Ray's token
authentication (on by default in Ray ≥ 2.5x) stays as Ray sets it.
"""

from __future__ import annotations

import ipaddress
import logging
import os
import signal
import threading
from typing import Any

from emonav_drake.params import ConfigError

LOCAL_ONLY_ENV = "RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER"


def _is_loopback(host: str) -> bool:
    try:
        return ipaddress.ip_address(host.strip("[]")).is_loopback
    except ValueError:
        return host == "localhost"


def init_ray(workers: int, address: str | None) -> Any:
    """Start (no `address`) or join (`address`) Ray and return the `ray` module.

    Args:
        workers: CPUs of a local Ray (ignored when joining a cluster).
        address: a Ray cluster's address ("auto", "HOST:6379"), or None for a local Ray
            that listens on loopback only.
    Raises:
        ConfigError: ray is not installed, or a local Ray would not be on loopback.
    """
    if not address:
        # before `import ray`: its constants are read at import, and Ray's processes
        # inherit the environment
        os.environ[LOCAL_ONLY_ENV] = "0"
    os.environ.setdefault("RAY_USAGE_STATS_ENABLED", "0")
    try:
        import ray
        from ray._private import ray_constants
    except ImportError:
        raise ConfigError("--workers > 1 needs ray (pip install ray), or use --workers 1") from None
    if not address:
        # ray imported earlier (by the user's own code): the constant was read already
        ray_constants.ENABLE_RAY_CLUSTER = False
    kwargs: dict[str, Any] = dict(
        include_dashboard=False,
        log_to_driver=False,
        logging_level=logging.ERROR,
        ignore_reinit_error=True,
    )
    # Ray's core worker installs its own SIGTERM handler in the driver (it would kill the
    # process at once); keep ours, which turns SIGTERM into a Ctrl-C (tables written, exit 130)
    main = threading.current_thread() is threading.main_thread()
    previous = signal.getsignal(signal.SIGTERM) if main else None
    if address:
        ray.init(address=address, **kwargs)
    else:
        ray.init(num_cpus=workers, **kwargs)
    if main and previous is not None:
        signal.signal(signal.SIGTERM, previous)
    if not address:
        node_ip = ray_node_address(ray)
        if not _is_loopback(node_ip):
            ray.shutdown()
            raise ConfigError(
                f"a local Ray would listen on {node_ip}, not on loopback: ray was imported "
                f"before emonav_drake could set {LOCAL_ONLY_ENV}=0; set it in the "
                "environment, or start a cluster yourself and pass --ray-address"
            )
    return ray


def ray_node_address(ray: Any) -> str:
    """The IP address this process's Ray node serves on (its servers bind to it)."""
    return str(ray._private.worker.global_worker.node.node_ip_address)
