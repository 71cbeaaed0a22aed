"""Rendering on a Ray cluster.

``render(words, workers=N)`` runs the ``lumo render`` command line ``words`` (scene first, then
its options, ``-o`` included) with the frame's sample passes cut into chunks, each a Ray task
on whatever node has a free CPU. Chunks come back as exact per-pixel sums (128-bit fixed-point
integers), which the driver checks (lumo version, plan, frame, sample range, image size) and
adds up, so the files written are byte for byte those of ``lumo render`` with the same options,
whatever the number of workers, the chunk size or the order in which chunks finish. A worker or
node that dies mid-chunk is survived through Ray's task retries: the chunk is rendered again
elsewhere and gives the same bits.

Scene distribution: every node reads the scene from the same path (a shared file system, or the
same files copied to each node); built-in scenes need no file. A worker that cannot read the
scene, or reads another file there (the plan fingerprint covers the command line, the scene
file's bytes and lumo's version), fails its task with a message naming its node, and nothing it
rendered reaches the image.

From the shell: ``python -m lumo.ray render SCENE [lumo render options] --workers N -o OUT``
(``--address`` joins a running cluster, ``--chunk-spp`` sets the chunk size).
"""

from __future__ import annotations

import os
import sys
import time
from typing import Dict, List, Optional, Sequence

from .. import LumoError, _native

__all__ = ["render", "default_chunk_spp", "loopback_only"]

#: Task retries after a worker or node dies (Ray's ``max_retries``).
MAX_RETRIES = 4

_PLANS: Dict[tuple, object] = {}


def _worker_plan(words: tuple):
    """The plan of ``words`` in this worker process, kept between tasks: Ray reuses worker
    processes, so the scene is loaded and its BVH built once per process, not per chunk."""
    plan = _PLANS.get(words)
    if plan is None:
        plan = _native.RenderPlan(list(words))
        _PLANS.clear()
        _PLANS[words] = plan
    return plan


def _render_chunk(words: tuple, plan_id: int, version: str, frame: int, first: int, count: int):
    """A Ray task: renders samples ``first..first + count`` of ``frame``; returns
    ``(node, chunk bytes)``."""
    import ray

    node = ray.get_runtime_context().get_node_id()[:12]
    if _native.version() != version:
        raise LumoError(
            f"worker on node {node}: lumo {_native.version()}, the driver runs lumo {version}; "
            f"install the same lumo on every node"
        )
    try:
        plan = _worker_plan(words)
    except LumoError as e:
        raise LumoError(f"worker on node {node} cannot plan the render: {e}") from None
    if plan.plan_id != plan_id:
        raise LumoError(
            f"worker on node {node}: the scene {words[0]!r} is not the driver's (another file at "
            f"that path, or other assets); every node must read the same scene file"
        )
    return node, plan.render_chunk(frame, first, count)


def loopback_only() -> None:
    """Keeps a Ray cluster started from this process on the loopback interface: Ray otherwise
    binds its services to the machine's network address, where a local render has no business.
    Call before starting a local cluster (``ray.init()`` without an address, or
    ``ray.cluster_utils.Cluster``); its worker processes inherit the setting."""
    os.environ["RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER"] = "0"
    constants = sys.modules.get("ray._private.ray_constants")
    if constants is not None:
        # Already imported: the flag was read at import time.
        constants.ENABLE_RAY_CLUSTER = False


def default_chunk_spp(spp: int, frames: int, cpus: int) -> int:
    """Samples per chunk: whole frames when there are at least two frames per CPU, else about
    four chunks per CPU (to even out nodes of different speed), never under one sample."""
    if frames >= 2 * cpus:
        return spp
    chunks_per_frame = max(1, -(-4 * cpus // frames))
    return max(1, -(-spp // chunks_per_frame))


def _progress(done: int, total: int, started: float) -> None:
    if not sys.stderr.isatty():
        return
    width = 40
    filled = width * done // max(total, 1)
    elapsed = time.monotonic() - started
    sys.stderr.write(
        f"\r{'█' * filled}{'░' * (width - filled)} {done}/{total} chunks  {elapsed:.1f} s"
    )
    if done == total:
        sys.stderr.write("\n")
    sys.stderr.flush()


class _NodePlacer:
    """Chooses the node for each chunk: the live node with the most free CPUs, counting the
    chunks this driver has in flight there. Ray's own placement (even SPREAD) reuses a worker it
    already leased when tasks are short, so all chunks could run on one node while the others
    idle; placing them ourselves keeps every node busy. Placement is soft: a chunk whose node
    died or is full runs wherever Ray finds room."""

    def __init__(self, nodes: Sequence[dict]):
        self.free: Dict[str, int] = {}
        for n in nodes:
            cpus = int(n.get("Resources", {}).get("CPU", 0))
            if n.get("Alive") and cpus >= 1:
                self.free[n["NodeID"]] = cpus

    def take(self) -> Optional[str]:
        """The node for the next chunk (None when no node is known: Ray chooses)."""
        if not self.free:
            return None
        # Ties go to the node listed first, so placement is reproducible.
        node = max(self.free, key=lambda k: self.free[k])
        self.free[node] -= 1
        return node

    def give_back(self, node: Optional[str]) -> None:
        """A chunk placed on ``node`` has finished (or failed)."""
        if node is not None and node in self.free:
            self.free[node] += 1


def render(
    words: Sequence[str],
    workers: Optional[int] = None,
    address: Optional[str] = None,
    chunk_spp: Optional[int] = None,
) -> Dict[str, object]:
    """Runs ``lumo render WORDS…`` on a Ray cluster and writes what ``lumo render`` writes.

    ``words`` are the words after ``lumo render`` (the scene, then its options). ``workers``
    caps the chunks rendered at once (default: every CPU of the cluster); ``address`` joins a
    running cluster (else a local one is started with ``workers`` CPUs, or the one this
    process already joined is used); ``chunk_spp`` is the samples per chunk (see
    :func:`default_chunk_spp`). Returns the files written, the counts and the timings.
    Raises :class:`lumo.LumoError` with lumo's message for a bad command line, or naming the
    worker's node when a worker fails."""
    import ray
    from ray.util.scheduling_strategies import NodeAffinitySchedulingStrategy

    words = [str(w) for w in words]
    if workers is not None and workers < 1:
        raise LumoError(f"--workers {workers}: at least 1")
    if chunk_spp is not None and chunk_spp < 1:
        raise LumoError(f"--chunk-spp {chunk_spp}: at least 1")
    t0 = time.monotonic()
    plan = _native.RenderPlan(words, driver=True)
    started_ray = False
    if not ray.is_initialized():
        if address is None:
            loopback_only()
            ray.init(num_cpus=workers, include_dashboard=False, log_to_driver=False)
        else:
            ray.init(address=address, log_to_driver=False)
        started_ray = True
    try:
        cpus = int(ray.cluster_resources().get("CPU", 1))
        slots = min(workers, cpus) if workers else cpus
        frames = plan.frames
        step = chunk_spp or default_chunk_spp(plan.spp, len(frames), slots)
        chunks = plan.chunks(step)
        # Each task renders on one thread: Ray runs as many tasks per node as it has CPUs.
        worker_words = tuple(words) + ("--threads", "1")
        task = ray.remote(num_cpus=1, max_retries=MAX_RETRIES)(_render_chunk)
        placer = _NodePlacer(ray.nodes())
        version = _native.version()
        pending = {}
        queue = list(chunks)

        def submit():
            while queue and len(pending) < slots:
                c = queue.pop(0)
                node_id = placer.take()
                options = {}
                if node_id is not None:
                    options["scheduling_strategy"] = NodeAffinitySchedulingStrategy(
                        node_id, soft=True
                    )
                ref = task.options(**options).remote(worker_words, plan.plan_id, version, *c)
                pending[ref] = (c, node_id)

        submit()
        t_plan = time.monotonic() - t0
        left = {f: sum(1 for c in chunks if c[0] == f) for f in frames}
        written: List[str] = []
        nodes: Dict[str, int] = {}
        samples = rays = 0
        reduce_s = finish_s = 0.0
        done = 0
        while pending:
            ready, _ = ray.wait(list(pending), num_returns=1)
            ref = ready[0]
            (frame, first, count), placed_on = pending.pop(ref)
            placer.give_back(placed_on)
            submit()
            try:
                node, data = ray.get(ref)
            except ray.exceptions.RayTaskError as e:
                cause = e.cause if isinstance(e.cause, LumoError) else e
                raise LumoError(f"chunk frame {frame} samples {first}..{first + count}: {cause}") from None
            tr = time.monotonic()
            try:
                plan.add_chunk(data, (frame, first, count))
            except LumoError as e:
                raise LumoError(f"chunk from worker on node {node} refused: {e}") from None
            reduce_s += time.monotonic() - tr
            nodes[node] = nodes.get(node, 0) + 1
            left[frame] -= 1
            done += 1
            _progress(done, len(chunks), t0)
            if left[frame] == 0:
                tf = time.monotonic()
                out = plan.finish(frame)
                finish_s += time.monotonic() - tf
                written += out["files"]
                samples += out["samples"]
                rays += out["rays"]
        total = time.monotonic() - t0
        return {
            "files": written,
            "frames": len(frames),
            "chunks": len(chunks),
            "chunk_spp": step,
            "workers": slots,
            "chunks_per_node": nodes,
            "samples": samples,
            "rays": rays,
            "seconds": total,
            "plan_seconds": t_plan,
            "reduce_seconds": reduce_s,
            "finish_seconds": finish_s,
        }
    finally:
        if started_ray:
            ray.shutdown()


def main(argv: Optional[Sequence[str]] = None) -> int:
    """``python -m lumo.ray render SCENE [lumo render options] --workers N -o OUT``."""
    args = list(sys.argv[1:] if argv is None else argv)
    usage = (
        "usage: python -m lumo.ray render SCENE [lumo render options] [--workers N] "
        "[--address ADDR] [--chunk-spp N]\n"
        "       python -m lumo.ray serve-workers --hub HOST:PORT --token HEX [--workers N] "
        "[--threads N] [--address ADDR]"
    )
    if not args or args[0] in ("-h", "--help"):
        print(usage)
        print(__doc__)
        return 0
    if args[0] == "serve-workers":
        return _serve_workers_main(args[1:])
    if args[0] != "render":
        print(f"error: unknown command {args[0]!r}\n{usage}", file=sys.stderr)
        return 2
    words: List[str] = []
    opts = {"--workers": None, "--address": None, "--chunk-spp": None}
    it = iter(args[1:])
    for w in it:
        name, eq, value = w.partition("=")
        if name in opts:
            if not eq:
                value = next(it, None)
                if value is None:
                    print(f"error: {name} needs a value\n{usage}", file=sys.stderr)
                    return 2
            opts[name] = value
        else:
            words.append(w)
    try:
        workers = int(opts["--workers"]) if opts["--workers"] is not None else None
        chunk = int(opts["--chunk-spp"]) if opts["--chunk-spp"] is not None else None
    except ValueError:
        print("error: --workers and --chunk-spp take whole numbers", file=sys.stderr)
        return 2
    try:
        out = render(words, workers=workers, address=opts["--address"], chunk_spp=chunk)
    except LumoError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    print(
        f"done in {out['seconds']:.2f} s · {out['samples'] / out['seconds'] / 1e6:.2f} Msamples/s · "
        f"{out['chunks']} chunks of {out['chunk_spp']} spp on {out['workers']} workers → "
        f"{', '.join(out['files'])}"
    )
    return 0


def _serve_workers_main(args: Sequence[str]) -> int:
    """``python -m lumo.ray serve-workers``: render workers for a ``lumo serve`` hub as Ray
    actors, until the hub closes (or Ctrl-C)."""
    import argparse

    from .serve import serve_workers

    ap = argparse.ArgumentParser(prog="python -m lumo.ray serve-workers")
    ap.add_argument("--hub", required=True, help="HOST:PORT from lumo serve's workers: line")
    ap.add_argument("--token", default=os.environ.get("LUMO_WORKER_TOKEN"),
                    help="the hub's token [LUMO_WORKER_TOKEN]")
    ap.add_argument("--workers", type=int, default=None, help="actors [one per CPU / threads]")
    ap.add_argument("--threads", type=int, default=1, help="render threads per actor [1]")
    ap.add_argument("--address", default=None, help="Ray cluster to join [a local one]")
    a = ap.parse_args(list(args))
    if not a.token:
        print("error: --token (or LUMO_WORKER_TOKEN) is required", file=sys.stderr)
        return 2
    workers = None
    try:
        workers = serve_workers(a.hub, a.token, a.workers, a.threads, a.address)
        print(f"{len(workers.actors)} workers for {a.hub}; Ctrl-C stops them", file=sys.stderr)
        workers.wait()
    except KeyboardInterrupt:
        if workers is not None:
            workers.stop()
    except LumoError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    return 0
