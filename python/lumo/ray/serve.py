"""Remote render workers for ``lumo serve --remote-workers`` as Ray actors.

``serve_workers(hub, token, workers=N)`` starts N Ray actors, spread over the cluster's nodes,
each running a lumo render worker (``lumo_server::remote::run_remote_worker``, the same code as
``lumo worker``) against the hub: it loads the hub's scene from the same path, renders sample
batches of the hub's current epoch (camera, edits, integrator) and streams them to the hub,
which merges them into the one stream its viewers receive (docs/remote-workers.md). An actor
whose process or node dies is restarted by Ray and reconnects; the hub drops a dead worker's
connection and its viewers keep receiving the other workers' and its own samples.

From the shell::

    lumo serve scenes/cornell.xml --remote-workers --worker-bind 0.0.0.0:8081
    python -m lumo.ray serve-workers --hub HOST:8081 --token TOKEN --workers 4 [--address auto]
"""

from __future__ import annotations

import os
import socket
from typing import List, Optional

from .. import LumoError, _native

__all__ = ["RemoteWorkers", "serve_workers"]


class _RemoteWorker:
    """A Ray actor running one render worker until the hub closes the connection."""

    def __init__(self, hub: str, token: str, name: str, threads: int):
        self.hub, self.token, self.threads = hub, token, threads
        import ray

        node = ray.get_runtime_context().get_node_id()[:8]
        # Name, node and process: a restarted actor shows up in the hub's log as a new process.
        self.name = f"{name}@{node}:{os.getpid()}"[:64]

    def run(self) -> str:
        _native.run_remote_worker(self.hub, self.token, self.name, self.threads)
        return self.name

    def pid(self) -> int:
        return os.getpid()


class RemoteWorkers:
    """The actors started by :func:`serve_workers`."""

    def __init__(self, actors, runs):
        self.actors = actors
        self._runs = runs

    def pids(self) -> List[int]:
        """The worker processes' ids (one per actor, as they are now)."""
        import ray

        return ray.get([a.pid.remote() for a in self.actors])

    def wait(self, timeout: Optional[float] = None) -> List[str]:
        """Waits until every worker has ended (the hub closed), re-raising a worker's error."""
        import ray

        return ray.get(self._runs, timeout=timeout)

    def stop(self) -> None:
        """Ends every worker: the hub sees their connections close."""
        import ray

        for a in self.actors:
            ray.kill(a, no_restart=True)


def serve_workers(
    hub: str,
    token: str,
    workers: Optional[int] = None,
    threads: int = 1,
    address: Optional[str] = None,
) -> RemoteWorkers:
    """Starts ``workers`` render-worker actors (default: one per CPU of the cluster divided by
    ``threads``) for the hub at ``hub`` (``HOST:PORT``, the ``workers:`` line of ``lumo serve
    --remote-workers``) with its ``token``; each renders on ``threads`` threads. Joins the
    cluster at ``address``, or starts a local one on the loopback interface when this process
    has none. Returns at once; the actors run until the hub closes or :meth:`stop`."""
    import ray

    from . import loopback_only

    if threads < 1:
        raise LumoError(f"threads {threads}: at least 1")
    host, _, port = hub.rpartition(":")
    if not host or not port.isdigit():
        raise LumoError(f"--hub {hub!r}: expected HOST:PORT, as `lumo serve --remote-workers` prints it")
    if not ray.is_initialized():
        if address is None:
            loopback_only()
            ray.init(include_dashboard=False, log_to_driver=False)
        else:
            ray.init(address=address, log_to_driver=False)
    if workers is None:
        workers = max(1, int(ray.cluster_resources().get("CPU", 1)) // threads)
    if workers < 1:
        raise LumoError(f"--workers {workers}: at least 1")
    # Two calls at once: `run` lasts the worker's life, `pid` must still answer.
    actor = ray.remote(
        num_cpus=threads, max_restarts=-1, max_task_retries=-1, max_concurrency=2
    )(_RemoteWorker)
    base = socket.gethostname()[:24]
    actors = [
        actor.options(scheduling_strategy="SPREAD").remote(hub, token, f"ray-{base}-{i}", threads)
        for i in range(workers)
    ]
    return RemoteWorkers(actors, [a.run.remote() for a in actors])
