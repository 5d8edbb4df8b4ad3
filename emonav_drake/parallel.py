"""The one owner of Ray: starting or joining it (closed to the network unless a cluster is
asked for), its actors, and the task pool every parallel job of the package runs on.

* `init_ray(workers, address)` is the one place the package starts Ray.
* `Worker` is the base of every actor: one thread of torch, quiet Drake, and `identity()`
  (the package's code hash), checked against the driver's by `start_actors`.
* `run_tasks` runs tasks on a pool of actors, `on_result` in the order they finish
  (benchmark trials, trace collection, Digit DAgger rounds); SAC's environments live in
  actors of their own (`learning/env_pool.py`), started by `start_actors` too.

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

import contextlib
import ipaddress
import logging
import os
import signal
import threading
from collections.abc import Callable, Sequence
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


# Tasks in flight per actor: two hide the round trip of a task's result.
IN_FLIGHT_PER_WORKER = 2


def quiet_process() -> None:
    """What every worker process does first: torch on one thread (one core per worker, and
    the arithmetic of a serial run), Drake's log at warnings."""
    import torch

    torch.set_num_threads(1)
    logging.getLogger("drake").setLevel(logging.WARNING)


class Worker:
    """Base of the package's Ray actors: `quiet_process()` at start, `identity()` the code
    hash of the package it runs (`start_actors` refuses an actor of other code)."""

    def __init__(self) -> None:
        quiet_process()

    def identity(self) -> str:
        from emonav_drake.provenance import code_hash

        return code_hash()


def ray_get(ray: Any, refs: list[Any]) -> list[Any]:
    """`ray.get(refs)`, re-raising a task's own exception (not Ray's wrapper)."""
    try:
        return ray.get(refs)
    except ray.exceptions.RayTaskError as e:
        cause = getattr(e, "cause", None)
        raise (cause if isinstance(cause, Exception) else e) from None


def start_actors(
    ray: Any, worker_cls: type, n: int, args: Sequence[Any], restartable: bool = False
) -> list[Any]:
    """`n` actors of `worker_cls(*args)` (a `Worker`), one CPU each; restartable ones are
    restarted (twice at most) after a crash and their tasks retried. Raises `ConfigError`
    (after shutting Ray down) if an actor runs other emonav_drake code than this driver."""
    from emonav_drake.provenance import code_hash

    options: dict[str, Any] = {"num_cpus": 1}
    if restartable:
        options.update(max_restarts=2, max_task_retries=2)
    actor_cls = ray.remote(**options)(worker_cls)
    actors = [actor_cls.remote(*args) for _ in range(n)]
    mine = code_hash()
    for ident in ray_get(ray, [a.identity.remote() for a in actors]):
        if ident != mine:
            ray.shutdown()
            raise ConfigError(
                "a Ray worker runs other emonav_drake code than this driver (code hash "
                f"{ident[:12]} vs {mine[:12]}); install the same version"
            )
    return actors


def run_tasks(
    worker_cls: type,
    tasks: Sequence[tuple],
    on_result: Callable[[Any], None],
    workers: int | None,
    address: str | None,
    args: Callable[[bool], Sequence[Any]],
) -> None:
    """Run `actor.run(*task)` for every task on a pool of `worker_cls` actors; `on_result`
    gets the results in the order they finish. Ray is shut down at the end.

    Args:
        workers: actors of a local Ray (no `address`); None with `address`: one per CPU
            of the cluster. Never more than there are tasks.
        args: `args(remote)` → the actors' constructor arguments; `remote` is True on a
            cluster, whose workers may be on other machines (ship bytes, not paths). There
            an actor is not restarted after a crash (what it was given is not kept): a
            crash stops the run. Local actors are restarted and their tasks retried (tasks
            must be deterministic).
    """
    ray = init_ray(workers or 1, address)
    try:
        if workers is None:  # a cluster: one worker per CPU it has
            workers = max(1, int(ray.cluster_resources().get("CPU", 1)))
        n = max(1, min(workers, len(tasks)))
        remote = bool(address)
        given = list(args(remote))
        if remote:  # through the object store once, not once per actor
            given = [ray.put(a) for a in given]
        actors = start_actors(ray, worker_cls, n, given, restartable=not remote)
        queue = list(reversed(tasks))
        pending: dict[Any, Any] = {}

        def submit(actor: Any) -> None:
            if queue:
                pending[actor.run.remote(*queue.pop())] = actor

        for _ in range(IN_FLIGHT_PER_WORKER):
            for a in actors:
                submit(a)
        while pending:
            ready, _ = ray.wait(list(pending), num_returns=1)
            for ref in ready:
                actor = pending.pop(ref)
                on_result(ray_get(ray, [ref])[0])
                submit(actor)
    finally:
        with contextlib.suppress(Exception):
            ray.shutdown()
