"""The one owner of Ray: starting or joining it (closed to the network unless a cluster is
asked for), its actors, and the task pool every parallel job of the package runs on.

* `init_ray(workers, address)` is the one place the package starts Ray; `check_workers`
  bounds a local Ray's `--workers` to `MAX_WORKERS_PER_CPU` per core of this machine
  (each actor is a process of its own: 100 000 of them would only exhaust the memory).
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
  (`docs/reliability.md`, "Network exposure"). `check_ray_address` first asks, within
  seconds, whether a Ray cluster answers there (Ray itself retries a dead address for
  minutes); `emonav benchmark` calls it before it writes any file.

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

log = logging.getLogger(__name__)

LOCAL_ONLY_ENV = "RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER"

# A local Ray's workers per CPU core: more only queue for the cores, each a process of
# ~0.4 GB (a Drake plant, torch, the planners).
MAX_WORKERS_PER_CPU = 4


def max_local_workers() -> int:
    """The most workers a local Ray may start here: `MAX_WORKERS_PER_CPU` per core."""
    return MAX_WORKERS_PER_CPU * (os.cpu_count() or 1)


def check_workers(workers: int, address: str | None, flag: str = "--workers") -> None:
    """`flag` (`workers`) must be >= 1 and, for a local Ray (no `address`), at most
    `max_local_workers()`; on a cluster its CPUs decide. Raises `ConfigError` naming it."""
    if workers < 1:
        raise ConfigError(f"{flag} {workers}: must be >= 1")
    if not address and workers > max_local_workers():
        cores = os.cpu_count() or 1
        raise ConfigError(
            f"{flag} {workers}: at most {max_local_workers()} on this machine "
            f"({MAX_WORKERS_PER_CPU} per CPU core, {cores} cores) for a local Ray; "
            "more would only queue for the cores; use --ray-address for a cluster"
        )


def _is_loopback(host: str) -> bool:
    try:
        return ipaddress.ip_address(host.strip("[]")).is_loopback
    except ValueError:
        return host == "localhost"


RAY_ADDRESS_FLAG = "--ray-address"
_CONNECT_TIMEOUT = 5.0  # [s] for the TCP connection, and again for the GCS's answer
# A call every Ray GCS answers (Ray's driver makes it first): with a cluster ID, or
# refused for want of the cluster's token — either way a GCS; anything else is not one.
_GCS_PROBE = "/ray.rpc.NodeInfoGcsService/GetClusterId"


def _no_cluster(address: str, why: str) -> ConfigError:
    return ConfigError(
        f"{RAY_ADDRESS_FLAG} {address}: {why}; start a cluster with `ray start --head` (on "
        f"the head machine; it prints the address to give), or drop {RAY_ADDRESS_FLAG} to "
        "run on this machine (--workers N)"
    )


def _not_an_address(address: str) -> ConfigError:
    return ConfigError(
        f"{RAY_ADDRESS_FLAG} {address}: not a Ray address; give auto or HOST:PORT (the GCS "
        "port of `ray start --head`, 6379 by default)"
    )


def _bootstrap_address(address: str) -> str:
    """The HOST:PORT (or ray://…) that `ray.init` is given for `--ray-address address`:
    Ray's own reading of it (`auto`: `RAY_ADDRESS`, else the cluster `ray start` recorded
    on this machine, else the one Ray running here; localhost becomes the node's address).
    `local` would start a Ray here instead of joining one: refused."""
    if address == "local":
        raise ConfigError(
            f"{RAY_ADDRESS_FLAG} local would start a new Ray here, not join a cluster; drop "
            f"{RAY_ADDRESS_FLAG} to run on this machine (--workers N, on loopback only)"
        )
    if "://" in address:  # Ray client: ray://HOST[:PORT]
        return address
    try:
        from ray._private.services import canonicalize_bootstrap_address_or_die
    except ImportError:
        raise ConfigError(f"{RAY_ADDRESS_FLAG} needs ray (pip install ray)") from None
    try:
        return canonicalize_bootstrap_address_or_die(address)
    except ConnectionError as e:  # `auto`: none found, or several (Ray's words name its flags)
        if "multiple" in str(e).lower():
            raise ConfigError(
                f"{RAY_ADDRESS_FLAG} {address}: several Ray clusters run on this machine; "
                "give the one to join as HOST:PORT"
            ) from None
        raise _no_cluster(address, "no running Ray cluster found on this machine") from None
    except (ValueError, TypeError):
        raise _not_an_address(address) from None


def _host_port(address: str) -> tuple[str, int]:
    """(host, port) of HOST:PORT, [IPv6]:PORT or ray://HOST[:PORT] (Ray client: 10001)."""
    rest = address.split("://", 1)[1].split("/", 1)[0] if "://" in address else address
    host, colon, port = rest.rpartition(":")
    if not colon or "]" in port:  # no port (ray://HOST, ray://[::1])
        host, port = rest, "10001"
    host = host.strip("[]")
    if not host or not port.isdigit() or not 0 < int(port) < 65536:
        raise _not_an_address(address)
    return host, int(port)


def check_ray_address(address: str) -> str:
    """The address to give `ray.init` for `--ray-address address` (`auto` resolved), if a
    Ray cluster answers there within seconds: the host is known, its port accepts a TCP
    connection and answers as a Ray GCS (a gRPC call every GCS answers; not checked for
    a Ray client address, ray://, or with `RAY_USE_TLS`). `ConfigError` naming
    `--ray-address` otherwise — Ray itself retries a dead address for minutes."""
    given = address
    address = _bootstrap_address(address)
    host, port = _host_port(address)
    import socket

    where = f"{host}:{port}" if ":" not in host else f"[{host}]:{port}"
    try:
        socket.create_connection((host, port), timeout=_CONNECT_TIMEOUT).close()
    except socket.gaierror as e:
        raise _no_cluster(given, f"the host {host!r} is unknown ({e.strerror})") from None
    except TimeoutError:
        why = f"Ray would connect to {where}: no answer within {_CONNECT_TIMEOUT:g} s"
        raise _no_cluster(given, why) from None
    except OSError as e:
        why = f"Ray would connect to {where}: nothing answers there ({e.strerror or e})"
        raise _no_cluster(given, why) from None
    if "://" in address or os.environ.get("RAY_USE_TLS", "0").lower() in ("1", "true"):
        return address  # another protocol, or TLS: the connection is what we can check
    import grpc

    with grpc.insecure_channel(where) as channel:
        try:
            channel.unary_unary(_GCS_PROBE)(b"", timeout=_CONNECT_TIMEOUT)
        except grpc.RpcError as e:
            code = e.code()  # type: ignore[attr-defined]  # a grpc.Call
            if code not in (grpc.StatusCode.UNAUTHENTICATED, grpc.StatusCode.PERMISSION_DENIED):
                why = (
                    f"Ray would connect to {where}: it accepts connections but does not "
                    f"answer as a Ray cluster ({code.name}: {e.details()})"  # type: ignore[attr-defined]
                )
                raise _no_cluster(given, why) from None
    return address


def init_ray(workers: int, address: str | None) -> Any:
    """Start (no `address`) or join (`address`) Ray and return the `ray` module.

    Args:
        workers: CPUs of a local Ray (ignored when joining a cluster).
        address: a Ray cluster's address ("auto", "HOST:6379"), or None for a local Ray
            that listens on loopback only.
    Raises:
        ConfigError: ray is not installed, a local Ray would not be on loopback, or no
            Ray cluster answers at `address` (`check_ray_address`).
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
        given, address = address, check_ray_address(address)
        try:
            ray.init(address=address, **kwargs)
        except (ConnectionError, SystemExit) as e:  # Ray exits when the GCS never answers
            with contextlib.suppress(Exception):
                ray.shutdown()
            raise _no_cluster(given, f"could not join it ({type(e).__name__}: {e})") from None
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
    recycle_after: int | None = None,
) -> None:
    """Run `actor.run(*task)` for every task on a pool of `worker_cls` actors; `on_result`
    gets the results in the order they finish. Ray is shut down at the end.

    `recycle_after`: an actor that has finished this many tasks is replaced by a fresh
    process (pydrake keeps every diagram with Python systems alive, Drake issue #22515: a
    worker that builds a camera diagram per task grows by tens of MB per task). Results do
    not depend on it: tasks are deterministic.

    Args:
        workers: actors of a local Ray (no `address`); None with `address`: one per CPU
            of the cluster. Never more than there are tasks.
        args: `args(remote)` → the actors' constructor arguments; `remote` is True on a
            cluster, whose workers may be on other machines (ship bytes, not paths).

    A task whose actor is lost (its machine fails or is cut off, or it crashes beyond its
    restarts: local actors are restarted twice) runs again on another actor, so the run
    completes with every result once; tasks must be deterministic. A task that has lost
    `MAX_TASK_LOSSES` actors, or the loss of every actor, stops the run (`WorkersLost`).
    """
    check_workers(workers or 1, address)
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

        def spawn() -> Any:
            return start_actors(ray, worker_cls, 1, given, restartable=not remote)[0]

        _pool(ray, actors, tasks, on_result, recycle_after, spawn)
    finally:
        with contextlib.suppress(Exception):
            ray.shutdown()


# A task whose actor died this many times is not tried again (it may be what kills them).
MAX_TASK_LOSSES = 3


class WorkersLost(RuntimeError):
    """Every Ray worker of a run was lost, or one task lost `MAX_TASK_LOSSES` of them."""


def _pool(
    ray: Any,
    actors: list[Any],
    tasks: Sequence[tuple],
    on_result: Callable,
    recycle_after: int | None = None,
    spawn: Callable[[], Any] | None = None,
) -> None:
    """`run_tasks`' loop: every live actor keeps `IN_FLIGHT_PER_WORKER` tasks; a lost
    actor's tasks go back to the queue for the others; with `recycle_after`, an actor that
    has been given that many tasks takes no more and, once idle (and while tasks are
    left), is replaced by `spawn()`."""
    queue = [(task, 0) for task in reversed(tasks)]  # (task, actors it has lost)
    pending: dict[Any, tuple[int, tuple, int]] = {}
    alive = list(range(len(actors)))
    assigned = [0] * len(actors)  # tasks given to the actor now in slot i

    def recycle() -> None:
        """Replace every actor that has had its `recycle_after` tasks and finished them."""
        if recycle_after is None:
            return
        for i in list(alive):
            busy = any(j == i for j, _, _ in pending.values())
            if assigned[i] < recycle_after or busy or not queue:
                continue
            ray.kill(actors[i])
            if spawn is None:
                alive.remove(i)
            else:
                actors[i], assigned[i] = spawn(), 0

    def top_up() -> None:
        for i in alive:
            if recycle_after is not None and assigned[i] >= recycle_after:
                continue
            load = sum(1 for j, _, _ in pending.values() if j == i)
            for _ in range(IN_FLIGHT_PER_WORKER - load):
                if not queue:
                    return
                if recycle_after is not None and assigned[i] >= recycle_after:
                    break
                task, losses = queue.pop()
                pending[actors[i].run.remote(*task)] = (i, task, losses)
                assigned[i] += 1

    top_up()
    while pending:
        ready, _ = ray.wait(list(pending), num_returns=1)
        for ref in ready:
            i, task, losses = pending.pop(ref)
            try:
                result = ray_get(ray, [ref])[0]
            except ray.exceptions.RayActorError as e:
                if i in alive:
                    alive.remove(i)
                    log.warning(
                        "a Ray worker was lost (%s); its tasks run again on the %d left",
                        str(e).splitlines()[0][:200],
                        len(alive),
                    )
                if losses + 1 >= MAX_TASK_LOSSES:
                    raise WorkersLost(
                        f"a task lost {losses + 1} Ray workers in a row: it may be what "
                        "kills them (rerun it serially, --workers 1, to see its error)"
                    ) from None
                if not alive:
                    raise WorkersLost(
                        "every Ray worker was lost (their machines failed or were cut off); "
                        "the results received so far are kept"
                    ) from None
                queue.append((task, losses + 1))
                continue
            on_result(result)
        recycle()
        top_up()
