"""lumo.ray on a local multi-node Ray cluster (three nodes of one CPU each): distributed
renders write the bytes of `lumo render`, also after a worker is killed mid-render, and
foreign, garbage or mislabelled chunks are refused naming the worker."""

import os
import signal
import threading
import time

import pytest

ray = pytest.importorskip("ray")

import lumo  # noqa: E402
import lumo.ray as lray  # noqa: E402
from lumo import LumoError, _native  # noqa: E402




def same_bytes(a, b):
    assert open(a, "rb").read() == open(b, "rb").read(), f"{a} and {b} differ"


def test_a_distributed_still_is_the_single_process_render(cluster, lumo_cli, tmp_path):
    words = ["cornell", "--size", "32x24", "--spp", "9", "--pipeline", "auto"]
    lumo_cli("render", *words, "-o", tmp_path / "one.exr")
    for workers, chunk in [(1, 9), (3, 2), (2, 1)]:
        out = tmp_path / f"ray-{workers}-{chunk}.exr"
        res = lray.render(words + ["-o", str(out)], workers=workers, chunk_spp=chunk)
        assert res["chunks"] == -(-9 // chunk) and res["files"] == [str(out)]
        same_bytes(tmp_path / "one.exr", out)


def test_chunks_spread_over_the_nodes(cluster, tmp_path):
    res = lray.render(["cornell", "--size", "64x64", "--spp", "12", "--pipeline", "none",
                       "-o", str(tmp_path / "x.exr")], chunk_spp=2)
    assert sum(res["chunks_per_node"].values()) == 6
    assert len(res["chunks_per_node"]) >= 2, res["chunks_per_node"]


def test_chunks_go_to_the_node_with_the_most_free_cpus():
    nodes = [
        {"NodeID": "a", "Alive": True, "Resources": {"CPU": 2.0}},
        {"NodeID": "dead", "Alive": False, "Resources": {"CPU": 8.0}},
        {"NodeID": "b", "Alive": True, "Resources": {"CPU": 1.0}},
        {"NodeID": "gpu-only", "Alive": True, "Resources": {"GPU": 1.0}},
    ]
    placer = lray._NodePlacer(nodes)
    # Dead and CPU-less nodes never get chunks; ties go to the first listed node.
    assert [placer.take() for _ in range(3)] == ["a", "a", "b"]
    # Every CPU is taken: the next chunk still gets a node (Ray queues it there or spills it).
    assert placer.take() in ("a", "b")
    placer.give_back("b")
    placer.give_back("b")
    assert placer.take() == "b"
    assert lray._NodePlacer([]).take() is None


def test_a_distributed_sequence_writes_the_same_files(cluster, lumo_cli, scenes, tmp_path):
    words = [str(scenes / "animated.gltf"), "--frames", "0..3", "--size", "24x16", "--spp", "4",
             "--pipeline", "atrous"]
    lumo_cli("render", *words, "-o", tmp_path / "one.exr", "--aovs", tmp_path / "one-aovs")
    res = lray.render(words + ["-o", str(tmp_path / "ray.exr"), "--aovs", str(tmp_path / "ray-aovs")],
                      chunk_spp=3)
    assert res["frames"] == 4
    for f in range(4):
        same_bytes(tmp_path / f"one_{f:04}.exr", tmp_path / f"ray_{f:04}.exr")
        same_bytes(tmp_path / "one-aovs" / f"{f:04}" / "albedo.exr",
                   tmp_path / "ray-aovs" / f"{f:04}" / "albedo.exr")


def _kill_a_chunk_worker(stop: threading.Event, killed: list):
    import psutil

    while not stop.is_set() and not killed:
        for p in psutil.process_iter(["pid", "cmdline"]):
            cmd = " ".join(p.info["cmdline"] or [])
            if "ray::_render_chunk" in cmd:
                try:
                    os.kill(p.info["pid"], signal.SIGKILL)
                    killed.append(p.info["pid"])
                except ProcessLookupError:
                    continue
                return
        time.sleep(0.02)


def test_bytes_are_unchanged_after_a_worker_is_killed_mid_render(cluster, lumo_cli, tmp_path):
    # Big enough that chunks are still running when the killer finds one.
    words = ["cornell", "--size", "96x96", "--spp", "16", "--pipeline", "atrous"]
    lumo_cli("render", *words, "-o", tmp_path / "one.exr")
    stop, killed = threading.Event(), []
    killer = threading.Thread(target=_kill_a_chunk_worker, args=(stop, killed))
    killer.start()
    try:
        lray.render(words + ["-o", str(tmp_path / "ray.exr")], chunk_spp=2)
    finally:
        stop.set()
        killer.join()
    assert killed, "no chunk worker was found to kill"
    same_bytes(tmp_path / "one.exr", tmp_path / "ray.exr")


def test_foreign_garbage_and_mislabelled_chunks_are_refused(cluster, tmp_path):
    words = ["cornell", "--size", "8x8", "--spp", "4", "-o", str(tmp_path / "x.exr")]
    plan = _native.RenderPlan(words, driver=True)
    with pytest.raises(LumoError, match="not a lumo chunk"):
        plan.add_chunk(b"garbage" * 100)
    other = _native.RenderPlan(["cornell", "--size", "8x8", "--spp", "4", "--seed", "2"])
    with pytest.raises(LumoError, match="another plan"):
        plan.add_chunk(other.render_chunk(0, 0, 2))
    mine = _native.RenderPlan(words).render_chunk(0, 2, 2)
    with pytest.raises(LumoError, match="were asked for"):
        plan.add_chunk(mine, (0, 0, 2))
    plan.add_chunk(mine, (0, 2, 2))
    with pytest.raises(LumoError, match="given twice"):
        plan.add_chunk(mine)
    with pytest.raises(LumoError, match="samples 0..2 are missing"):
        plan.finish(0)
    with pytest.raises(LumoError, match="frame 3"):
        _native.RenderPlan(["cornell", "--size", "8x8", "--spp", "4"]).render_chunk(3, 0, 2)
    bad_words = tuple(words)
    task = ray.remote(num_cpus=1, max_retries=0)(lray._render_chunk)
    with pytest.raises(ray.exceptions.RayTaskError, match="node .*lumo 0.0.0"):
        ray.get(task.remote(bad_words, plan.plan_id, "0.0.0", 0, 0, 2))
    with pytest.raises(ray.exceptions.RayTaskError, match="not the driver's"):
        ray.get(task.remote(bad_words, plan.plan_id ^ 1, _native.version(), 0, 0, 2))
    missing = ("/nonexistent/scene.xml", "--spp", "4")
    with pytest.raises(ray.exceptions.RayTaskError, match="cannot plan the render.*does not exist"):
        ray.get(task.remote(missing, 0, _native.version(), 0, 0, 2))


def test_what_cannot_be_distributed_is_refused_before_any_task(cluster, tmp_path):
    for extra, says in [(["--integrator", "bdpt"], "integrator"), (["--pipeline", "guided"], "guided")]:
        with pytest.raises(LumoError, match=says):
            lray.render(["cornell", "--size", "8x8", *extra, "-o", str(tmp_path / "x.exr")])
