#!/usr/bin/env python3
"""Peak memory of single requests against the daemon's admission estimate (daemon/jobs/memory.hpp).

For each case: the daemon's peak RSS is reset (/proc/PID/clear_refs "5", Linux >= 4.0; needs
the daemon's uid or root), one request is sent alone, and the new peak (VmHWM) minus the RSS
before is compared with the estimate the daemon sent back (X-Hdrd-Memory-Estimate). After
the request, the RSS left resident is read too. Used for the "Memory" table in
docs/performance-daemon.md:

  scripts/measure-request-memory.py --socket /tmp/x/hdrd.sock --pid PID
"""
import argparse, http.client, json, socket, time


class Unix(http.client.HTTPConnection):
    def __init__(self, path):
        super().__init__("localhost", timeout=600)
        self.path_ = path

    def connect(self):
        s = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        s.settimeout(600)
        s.connect(self.path_)
        self.sock = s


def status_kib(pid, key):
    with open(f"/proc/{pid}/status") as f:
        for line in f:
            if line.startswith(key + ":"):
                return int(line.split()[1])
    return -1


def send(sock, method, path, body, headers):
    c = Unix(sock)
    c.request(method, path, body=body, headers=headers)
    r = c.getresponse()
    data = r.read()
    h = {k.lower(): v for k, v in r.getheaders()}
    c.close()
    return r.status, h, data


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--socket", required=True)
    ap.add_argument("--pid", type=int, required=True)
    ap.add_argument("--renders", action="store_true", help="include renders (needs a renderer)")
    a = ap.parse_args()
    exr_small = send(a.socket, "POST", "/v1/pattern", json.dumps({"pattern": "pq-ramp", "width": 64, "height": 36}),
                     {"Accept": "image/x-exr"})[2]
    cases = []
    if a.renders:
        for w, h, s, acc in [(1920, 1080, 1, "image/png"), (1920, 1080, 4, "image/png"), (3840, 2160, 1, "image/png"),
                             (3840, 2160, 4, "image/x-exr"), (7680, 4320, 1, "application/octet-stream")]:
            cases.append((f"render {w}x{h} x{s} {acc}", "POST", "/v1/render",
                          json.dumps({"width": w, "height": h, "samples": s}), {"Accept": acc}))
    for w, h, acc in [(1920, 1080, "image/png"), (3840, 2160, "image/x-exr"), (7680, 4320, "image/png")]:
        cases.append((f"pattern {w}x{h} {acc}", "POST", "/v1/pattern",
                      json.dumps({"pattern": "pq-ramp", "width": w, "height": h}), {"Accept": acc}))
    big = send(a.socket, "POST", "/v1/pattern", json.dumps({"pattern": "pq-ramp", "width": 3840, "height": 2160}),
               {"Accept": "image/x-exr"})[2]
    cases.append(("encode upload 3840x2160 EXR -> PNG", "POST", "/v1/encode?mode=hdr10", big,
                  {"Content-Type": "image/x-exr", "Accept": "image/png"}))
    cases.append(("encode upload 64x36 EXR -> raw", "POST", "/v1/encode?mode=hdr10", exr_small,
                  {"Content-Type": "image/x-exr", "Accept": "application/octet-stream"}))
    rows = []
    for name, method, path, body, headers in cases:
        time.sleep(1.0)
        before = status_kib(a.pid, "VmRSS")
        with open(f"/proc/{a.pid}/clear_refs", "w") as f:
            f.write("5")
        t0 = time.time()
        st, h, data = send(a.socket, method, path, body, headers)
        seconds = time.time() - t0
        time.sleep(0.5)
        peak = status_kib(a.pid, "VmHWM")
        after = status_kib(a.pid, "VmRSS")
        est = int(h.get("x-hdrd-memory-estimate", "0"))
        rows.append({"case": name, "status": st, "seconds": round(seconds, 2),
                     "estimate_mib": round(est / 2**20, 1), "peak_over_before_mib": round((peak - before) / 1024, 1),
                     "rss_after_minus_before_mib": round((after - before) / 1024, 1),
                     "estimate_covers_peak": est >= (peak - before) * 1024})
        print(json.dumps(rows[-1]), flush=True)


if __name__ == "__main__":
    main()
