#!/usr/bin/env python3
"""How a running `hdrd serve` answers new clients while others misbehave (issue 14).

Two scenes, each for DURATION seconds, with a probe that opens a new connection every
PERIOD seconds and times GET /v1/status (5 s client timeout):
  slow   N connections that each send one byte of a request per second;
  flood  M connections opened at once and held idle.
Prints, per scene, the probes answered, the median and worst latency, and how many of the
abusive connections the daemon closed. Used for the table in docs/performance-daemon.md:

  scripts/probe-abuse.py --socket /tmp/x/hdrd.sock [--slow 64] [--flood 2000] [--duration 20]
"""
import argparse, json, os, resource, socket, statistics, threading, time


def probe_once(path, timeout=5.0):
    t0 = time.time()
    s = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    s.settimeout(timeout)
    try:
        s.connect(path)
        s.sendall(b"GET /v1/status HTTP/1.1\r\nHost: p\r\nConnection: close\r\n\r\n")
        data = b""
        while b"\r\n\r\n" not in data:
            b = s.recv(4096)
            if not b:
                break
            data += b
        ok = data.startswith(b"HTTP/1.1 200")
    except OSError:
        ok = False
    finally:
        s.close()
    return ok, time.time() - t0


def run_probes(path, duration, period, out):
    end = time.time() + duration
    while time.time() < end:
        t0 = time.time()
        out.append(probe_once(path))
        time.sleep(max(0.0, period - (time.time() - t0)))


def closed_by_peer(s):
    try:
        return s.recv(1, socket.MSG_PEEK | socket.MSG_DONTWAIT) == b""
    except BlockingIOError:
        return False
    except OSError:
        return True


def scene_slow(path, n, duration, period):
    socks = []
    for _ in range(n):
        s = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        s.connect(path)
        s.setblocking(False)
        socks.append(s)
    req = b"GET /v1/status HTTP/1.1\r\nHost: x\r\nX-Pad: " + b"p" * 4096 + b"\r\n\r\n"
    probes, stop = [], [False]

    def trickle():
        i = 0
        while not stop[0] and i < len(req):
            for s in socks:
                try:
                    s.send(req[i:i + 1])
                except OSError:
                    pass
            i += 1
            time.sleep(1.0)

    t = threading.Thread(target=trickle)
    t.start()
    time.sleep(1.0)
    run_probes(path, duration, period, probes)
    stop[0] = True
    t.join()
    closed = sum(closed_by_peer(s) for s in socks)
    for s in socks:
        s.close()
    return probes, closed


def scene_flood(path, m, duration, period):
    socks, refused = [], 0
    t0 = time.time()
    for _ in range(m):
        # Non-blocking: a Unix socket's connect fails with EAGAIN at once when the listen
        # backlog is full (a server that stopped accepting), instead of waiting.
        s = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        s.setblocking(False)
        if s.connect_ex(path) == 0:
            socks.append(s)
        else:
            refused += 1
            s.close()
    opened_s = time.time() - t0
    probes = []
    run_probes(path, duration, period, probes)
    closed = sum(closed_by_peer(s) for s in socks)
    for s in socks:
        s.close()
    return probes, closed, refused, opened_s


def summary(probes):
    lat = sorted(dt for ok, dt in probes if ok)
    return {"probes": len(probes), "answered": sum(ok for ok, _ in probes),
            "median_ms": round(1e3 * statistics.median(lat), 1) if lat else None,
            "worst_ms": round(1e3 * max(dt for _, dt in probes), 1) if probes else None}


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--socket", required=True)
    ap.add_argument("--slow", type=int, default=64)
    ap.add_argument("--flood", type=int, default=2000)
    ap.add_argument("--duration", type=float, default=20)
    ap.add_argument("--period", type=float, default=0.5)
    a = ap.parse_args()
    soft, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
    resource.setrlimit(resource.RLIMIT_NOFILE, (hard, hard))
    out = {}
    probes, closed = scene_slow(a.socket, a.slow, a.duration, a.period)
    out["slow"] = dict(summary(probes), connections=a.slow, closed_by_daemon=closed)
    time.sleep(2)
    probes, closed, refused, opened_s = scene_flood(a.socket, a.flood, a.duration, a.period)
    out["flood"] = dict(summary(probes), connections=a.flood, connect_failed=refused,
                        closed_by_daemon=closed, seconds_to_open=round(opened_s, 2))
    print(json.dumps(out, indent=2))


if __name__ == "__main__":
    main()
