#!/usr/bin/env python3
"""Soak test for `lumo serve` (issue 25): hostile clients and two good viewers, on loopback.

Starts `lumo serve` on 127.0.0.1 (a free port), then for --minutes runs --bad misbehaving
clients, cycling through the probes of issue 25 (each reconnects when the server closes it):

  garbage   4-byte messages of an unknown type as fast as possible, never reading
  cameras   valid CAMERAs as fast as possible, never reading
  reader    valid CAMERAs as fast as possible, reading everything
  stalled   a viewer that never reads nor sends
  idle      a raw TCP connection that never sends a byte
  slowloris a request whose header lines trickle in forever
  badhost   requests with `Host: [`, `Host: [::1`, two Host headers, `localhost:1@evil`

and --good well-behaved viewers (in a separate process, so the flood does not delay their
reading) that record the time of every STATS message. Reports the server's peak RSS (sampled
from /proc every 100 ms, and VmHWM) and the good viewers' longest gap between two STATS
(targets: RSS < 200 MB, gap < 1 s). Everything is bounded: the run ends after --minutes, and
the server and the viewer process are killed by PID at the end.

Usage: scripts/soak_serve.py [--lumo target/release/lumo] [--minutes 5] [--bad 50] [--good 2]
Needs only the Python standard library.
"""

import argparse
import asyncio
import base64
import multiprocessing as mp
import os
import re
import struct
import subprocess
import sys
import time

VERSION = 1
CAMERA, STATS, HELLO = 0x02, 0x12, 0x01
KINDS = ["garbage", "cameras", "reader", "stalled", "idle", "slowloris", "badhost"]


# ---------------------------------------------------------------- a minimal WebSocket client


async def ws_connect(port):
    """Opens a WebSocket to 127.0.0.1:port/ws; returns (reader, writer) after the handshake."""
    r, w = await asyncio.open_connection("127.0.0.1", port)
    key = base64.b64encode(os.urandom(16)).decode()
    w.write(
        (
            f"GET /ws HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\nUpgrade: websocket\r\n"
            f"Connection: Upgrade\r\nSec-WebSocket-Key: {key}\r\n"
            "Sec-WebSocket-Version: 13\r\n\r\n"
        ).encode()
    )
    await w.drain()
    head = await asyncio.wait_for(r.readuntil(b"\r\n\r\n"), 10)
    if not head.startswith(b"HTTP/1.1 101"):
        w.close()
        raise ConnectionError(head.split(b"\r\n")[0].decode(errors="replace"))
    return r, w


def ws_frame(payload, opcode=2):
    """A masked client frame."""
    mask = os.urandom(4)
    n = len(payload)
    if n < 126:
        head = struct.pack("!BB", 0x80 | opcode, 0x80 | n)
    elif n < 65536:
        head = struct.pack("!BBH", 0x80 | opcode, 0x80 | 126, n)
    else:
        head = struct.pack("!BBQ", 0x80 | opcode, 0x80 | 127, n)
    masked = bytes(b ^ mask[i % 4] for i, b in enumerate(payload))
    return head + mask + masked


async def ws_read(r):
    """Reads one server frame; returns (opcode, payload)."""
    b0, b1 = await r.readexactly(2)
    n = b1 & 0x7F
    if n == 126:
        (n,) = struct.unpack("!H", await r.readexactly(2))
    elif n == 127:
        (n,) = struct.unpack("!Q", await r.readexactly(8))
    return b0 & 0x0F, await r.readexactly(n)


def camera_msg(eye_y):
    return struct.pack(
        "<BBHI10f", CAMERA, VERSION, 0, 0, 0.0, eye_y, 3.9, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 40.0
    )


# ---------------------------------------------------------------- misbehaving clients


async def bad_client(kind, port, deadline, counts):
    """Runs one misbehaving client of `kind` until `deadline`, reconnecting when closed."""
    while time.monotonic() < deadline:
        try:
            await asyncio.wait_for(bad_once(kind, port, deadline), max(0.1, deadline - time.monotonic()))
        except (asyncio.TimeoutError, ConnectionError, OSError, asyncio.IncompleteReadError):
            pass
        counts[kind] = counts.get(kind, 0) + 1
        await asyncio.sleep(0.05)


async def bad_once(kind, port, deadline):
    if kind in ("idle", "slowloris", "badhost"):
        r, w = await asyncio.open_connection("127.0.0.1", port)
        try:
            if kind == "idle":
                await r.read(1)  # returns when the server closes the connection
            elif kind == "slowloris":
                w.write(b"GET / HTTP/1.1\r\nHost: localhost\r\n")
                i = 0
                while time.monotonic() < deadline:
                    w.write(f"X-{i}: y\r\n".encode())
                    await w.drain()
                    i += 1
                    await asyncio.sleep(0.5)
            else:
                for host in ["[", "[::1", "localhost:1@evil", "localhost\r\nHost: evil"]:
                    w.write(f"GET / HTTP/1.1\r\nHost: {host}\r\n\r\n".encode())
                    await w.drain()
                    await asyncio.sleep(0.05)
                await r.read(65536)
        finally:
            w.close()
        return
    r, w = await ws_connect(port)
    try:
        if kind == "stalled":
            while time.monotonic() < deadline:
                await asyncio.sleep(1)
                if w.is_closing():
                    return
        elif kind == "reader":
            async def drain():
                while True:
                    await ws_read(r)

            task = asyncio.ensure_future(drain())
            try:
                i = 0
                while time.monotonic() < deadline and not task.done():
                    w.write(ws_frame(camera_msg(0.5 + (i % 100) * 1e-3)))
                    await w.drain()
                    i += 1
                    if i % 64 == 0:
                        await asyncio.sleep(0)  # drain() does not yield while the buffer is low
            finally:
                task.cancel()
                try:
                    await task
                except BaseException:  # noqa: B036 - cancelled, or the server closed it
                    pass
        else:
            msg = bytes([0x55, VERSION, 0, 0]) if kind == "garbage" else None
            i = 0
            while time.monotonic() < deadline:
                w.write(ws_frame(msg or camera_msg(0.5 + (i % 100) * 1e-3)))
                await w.drain()
                i += 1
                if i % 64 == 0:
                    await asyncio.sleep(0)
    finally:
        w.close()


async def run_bad(port, n, seconds):
    deadline = time.monotonic() + seconds
    counts = {}
    tasks = [asyncio.ensure_future(bad_client(KINDS[i % len(KINDS)], port, deadline, counts)) for i in range(n)]
    await asyncio.gather(*tasks, return_exceptions=True)
    return counts


# ---------------------------------------------------------------- good viewers


async def good_viewer(port, deadline, out):
    r, w = await ws_connect(port)
    last = None
    worst = 0.0
    stats = 0
    data_bytes = 0
    closed = False
    try:
        while time.monotonic() < deadline:
            left = deadline - time.monotonic()
            try:
                op, payload = await asyncio.wait_for(ws_read(r), max(0.01, left))
            except asyncio.TimeoutError:
                break
            if op == 8:
                closed = True
                break
            if op == 2 and payload and payload[0] == STATS:
                now = time.monotonic()
                if last is not None:
                    worst = max(worst, now - last)
                last = now
                stats += 1
            data_bytes += len(payload)
    except (asyncio.IncompleteReadError, ConnectionError):
        closed = True
    finally:
        w.close()
    out.append({"worst_gap_s": worst, "stats": stats, "bytes": data_bytes, "closed_early": closed})


def good_process(port, n, seconds, queue):
    async def main():
        deadline = time.monotonic() + seconds
        out = []
        await asyncio.gather(*[good_viewer(port, deadline, out) for _ in range(n)])
        return out

    queue.put(asyncio.run(main()))


# ---------------------------------------------------------------- the run


def rss_kb(pid, field="VmRSS"):
    try:
        with open(f"/proc/{pid}/status") as f:
            for line in f:
                if line.startswith(field + ":"):
                    return int(line.split()[1])
    except OSError:
        pass
    return 0


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--lumo", default="target/release/lumo")
    ap.add_argument("--scene", default="cornell")
    ap.add_argument("--size", default="256x256")
    ap.add_argument("--minutes", type=float, default=5.0)
    ap.add_argument("--bad", type=int, default=50)
    ap.add_argument("--good", type=int, default=2)
    args = ap.parse_args()
    seconds = args.minutes * 60.0

    server = subprocess.Popen(
        [args.lumo, "serve", args.scene, "--port", "0", "--bind", "127.0.0.1", "--size", args.size],
        stdout=subprocess.PIPE,
        stderr=subprocess.DEVNULL,
        text=True,
    )
    viewers = None
    try:
        line = server.stdout.readline()
        m = re.search(r"http://127\.0\.0\.1:(\d+)", line)
        if not m:
            sys.exit(f"lumo serve did not print its address: {line!r}")
        port = int(m.group(1))
        rss_start = rss_kb(server.pid)
        queue = mp.Queue()
        viewers = mp.Process(target=good_process, args=(port, args.good, seconds, queue))
        viewers.start()
        time.sleep(1.0)  # the good viewers connect first, as a user would

        peak = [0]

        async def sample():
            end = time.monotonic() + seconds
            while time.monotonic() < end:
                peak[0] = max(peak[0], rss_kb(server.pid))
                await asyncio.sleep(0.1)

        async def both():
            s = asyncio.ensure_future(sample())
            counts = await run_bad(port, args.bad, seconds - 1.0)
            await s
            return counts

        counts = asyncio.run(both())
        good = queue.get(timeout=60)
        viewers.join(timeout=10)
        hwm = rss_kb(server.pid, "VmHWM")
        rss_end = rss_kb(server.pid)
    finally:
        if viewers is not None and viewers.is_alive():
            os.kill(viewers.pid, 9)
        server.kill()
        server.wait()

    worst = max(g["worst_gap_s"] for g in good)
    print(f"lumo serve {args.scene} {args.size}, {args.minutes:g} min, {args.bad} misbehaving clients, {args.good} good viewers")
    print(f"  RSS: start {rss_start / 1024:.0f} MB, peak sampled {peak[0] / 1024:.0f} MB, VmHWM {hwm / 1024:.0f} MB, end {rss_end / 1024:.0f} MB")
    print(f"  good viewers: longest STATS gap {worst:.3f} s; " + "; ".join(
        f"{g['stats']} STATS, {g['bytes'] / 1e6:.0f} MB{' (closed early!)' if g['closed_early'] else ''}" for g in good))
    print("  misbehaving connections made: " + ", ".join(f"{k} {v}" for k, v in sorted(counts.items())))
    ok = hwm < 200 * 1024 and worst < 1.0 and not any(g["closed_early"] for g in good)
    print("  targets (RSS < 200 MB, gap < 1 s): " + ("met" if ok else "NOT met"))
    sys.exit(0 if ok else 1)


if __name__ == "__main__":
    main()
