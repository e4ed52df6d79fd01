#!/usr/bin/env bash
# Bounded soak of `hdrd serve`: N mixed requests (renders, encodes, patterns, self-tests,
# dumps, GETs; 10 % malformed, some clients hanging up
# mid-request) from C concurrent clients over a temporary Unix socket (nothing else is
# reachable), then checks: the daemon never crashed and exits 0 on SIGTERM, its RSS grew
# < 5 % between the end of the warm-up and the end, every well-formed request got a
# correct answer, every malformed one a 4xx, and the dump directory holds no partial file.
# Stops by itself. Not part of ctest (it takes minutes); docs/performance-daemon.md has
# the numbers of the last run.
#
# Usage: scripts/soak.sh [-n REQUESTS] [-c CLIENTS] [-w WARMUP] [-b BUILD_DIR]
set -euo pipefail
cd "$(dirname "$0")/.."

requests=10000
clients=4
warmup=1000
build_dir=${BUILD_DIR:-build}
while getopts "n:c:w:b:h" opt; do
  case $opt in
    n) requests=$OPTARG ;;
    c) clients=$OPTARG ;;
    w) warmup=$OPTARG ;;
    b) build_dir=$OPTARG ;;
    *) sed -n '2,12p' "$0"; exit 2 ;;
  esac
done

hdrd="$build_dir/tools/hdrd"
[ -x "$hdrd" ] || { echo "soak: $hdrd not built (cmake --build $build_dir --target hdrd)" >&2; exit 2; }

work=$(mktemp -d /tmp/hdrd-soak.XXXXXX)
daemon_pid=""
cleanup() {
  if [ -n "$daemon_pid" ] && kill -0 "$daemon_pid" 2>/dev/null; then kill -KILL "$daemon_pid" 2>/dev/null || true; fi
  rm -rf "$work"
}
trap cleanup EXIT

mkdir -p "$work/assets" "$work/dumps"
printf '{}' > "$work/assets/empty.json"
cat > "$work/hdrd.toml" <<EOF
[server]
socket_path = "$work/hdrd.sock"
connection_timeout_s = 2
max_connections = 256
[workers]
render_workers = 1
encode_threads = 2
queue_depth = 64
[paths]
asset_root = "$work/assets"
dump_dir = "$work/dumps"
[limits]
max_body_bytes = 65536
max_upload_bytes = 1048576
max_request_seconds = 60
[log]
level = "warn"
access_log = false
EOF

"$hdrd" serve --config "$work/hdrd.toml" > "$work/daemon.log" 2>&1 &
daemon_pid=$!

set +e
python3 - "$work" "$daemon_pid" "$requests" "$clients" "$warmup" <<'PY'
import http.client, json, os, random, socket, struct, sys, threading, time, zlib

work, pid, total, clients, warmup = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), int(sys.argv[4]), int(sys.argv[5])
sock_path = os.path.join(work, "hdrd.sock")

class UnixConnection(http.client.HTTPConnection):
    def __init__(self):
        super().__init__("localhost", timeout=120)
    def connect(self):
        s = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        s.settimeout(120)
        s.connect(sock_path)
        self.sock = s

def rss_kib():
    with open(f"/proc/{pid}/status") as f:
        for line in f:
            if line.startswith("VmRSS:"):
                return int(line.split()[1])
    return -1

for _ in range(600):
    try:
        c = UnixConnection(); c.request("GET", "/v1/status"); r = c.getresponse(); r.read(); c.close()
        if r.status == 200: break
    except OSError:
        time.sleep(0.05)
else:
    sys.exit("soak: the daemon did not come up")

# A tiny EXR for /v1/encode, made by the daemon itself (a render as image/x-exr).
c = UnixConnection()
c.request("POST", "/v1/render", json.dumps({"width": 32, "height": 18}), {"Accept": "image/x-exr"})
r = c.getresponse(); exr = r.read(); c.close()
assert r.status == 200, r.status

modes = ["hdr10", "hlg", "sdr", "sdr-bt1886", "scrgb"]
def valid_request(rng):
    kind = rng.random()
    if kind < 0.55:
        w, h = rng.choice([(64, 36), (96, 54), (128, 72), (32, 18)])
        mode = rng.choice(modes)
        body = {"width": w, "height": h, "display": {"mode": mode},
                "exposure_comp_ev": rng.choice([-1, -0.5, 0, 0.5, 1])}
        if rng.random() < 0.3:
            body["tone"] = {"curve": rng.choice(["clip", "reinhard", "bt2390"])}
        accept = rng.choice(["image/png", "application/octet-stream", "image/x-exr"])
        if mode == "scrgb" and accept == "image/png": accept = "image/x-exr"
        return ("render", "POST", "/v1/render", json.dumps(body), {"Content-Type": "application/json", "Accept": accept}, (w, h))
    if kind < 0.60:
        w, h = rng.choice([(64, 36), (96, 54), (192, 108)])
        mode = rng.choice(["hdr10", "hlg"])
        name = rng.choice(["bt2111", "pq-ramp", "window", "near-black", "clipping", "sdr-grey"])
        body = {"pattern": name, "width": w, "height": h, "display": {"mode": mode}}
        if name == "window":
            body["params"] = {"level_nits": rng.choice([100, 203, 600, 1000]), "area_percent": rng.choice([1, 10, 25])}
        accept = rng.choice(["image/png", "application/octet-stream", "image/x-exr"])
        return ("pattern", "POST", "/v1/pattern", json.dumps(body), {"Content-Type": "application/json", "Accept": accept}, (w, h))
    if kind < 0.605:
        body = {"mode": rng.choice(["hdr10", "hlg", "sdr", "scrgb", "sdr-bt1886"]), "render": rng.random() < 0.5}
        return ("selftest", "POST", "/v1/selftest", json.dumps(body), {"Content-Type": "application/json"}, None)
    if kind < 0.70:
        mode = rng.choice(modes)
        return ("encode", "POST", f"/v1/encode?mode={mode}", exr, {"Content-Type": "image/x-exr", "Accept": "application/octet-stream"}, (32, 18))
    if kind < 0.75:
        body = {"width": 32, "height": 18, "dump": True, "name": f"soak-{rng.randrange(20)}",
                "formats": rng.choice([["png", "raw"], ["exr"], ["png", "exr", "raw"]])}
        return ("dump", "POST", "/v1/render", json.dumps(body), {"Content-Type": "application/json", "Accept": "application/json"}, None)
    path = rng.choice(["/v1/status", "/v1/capabilities", "/v1/displays", "/metrics"])
    return ("get", "GET", path, None, {}, None)

def malformed_request(rng):
    return rng.choice([
        ("POST", "/v1/render", '{"width":64,', "application/json"),
        ("POST", "/v1/render", '{"width":"64"}', "application/json"),
        ("POST", "/v1/render", '{"widht":64}', "application/json"),
        ("POST", "/v1/render", '{"width":100000000,"height":100000000}', "application/json"),
        ("POST", "/v1/render", '{"gltf":"../../../etc/passwd"}', "application/json"),
        ("POST", "/v1/render", '{"scene_file":"/etc/shadow"}', "application/json"),
        ("POST", "/v1/render", '{"dump":true,"name":"../escape"}', "application/json"),
        ("POST", "/v1/render", "[" * 100 + "]" * 100, "application/json"),
        ("POST", "/v1/render", '{"scene":{"pad":"' + "x" * 70000 + '"}}', "application/json"),
        ("POST", "/v1/render", "{}", "image/png"),
        ("GET", "/v1/render", None, None),
        ("DELETE", "/v1/status", None, None),
        ("POST", "/v1/encode", "not an exr", "image/x-exr"),
        ("POST", "/v1/encode?colour=red", "x", "image/x-exr"),
        ("GET", "/nope", None, None),
        ("POST", "/v1/pattern", '{"pattern":"smpte"}', "application/json"),
        ("POST", "/v1/pattern", '{"pattern":"window","params":{"level":5}}', "application/json"),
        ("POST", "/v1/pattern", '{"pattern":"bt2111","display":{"mode":"sdr"}}', "application/json"),
        ("POST", "/v1/selftest", '{"mode":"hdr12"}', "application/json"),
    ])

def raw_abuse(rng):
    """Truncated bodies, garbage and hang-ups mid-request; answers are not read."""
    s = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    s.settimeout(5)
    s.connect(sock_path)
    choice = rng.random()
    if choice < 0.4:    # a real render, then hang up before the answer
        body = json.dumps({"width": 256, "height": 144, "exposure_comp_ev": rng.random()})
        s.sendall(f"POST /v1/render HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\nContent-Length: {len(body)}\r\n\r\n{body}".encode())
        time.sleep(rng.random() * 0.05)
    elif choice < 0.7:  # truncated body
        s.sendall(b"POST /v1/render HTTP/1.1\r\nHost: x\r\nContent-Length: 500\r\n\r\n{\"width\":")
    else:               # not HTTP
        s.sendall(bytes(rng.randrange(256) for _ in range(64)) + b"\r\n\r\n")
    s.close()

PNG_SIG = b"\x89PNG\r\n\x1a\n"
stats = {"ok": 0, "malformed_sent": 0, "malformed_4xx": 0, "abuse": 0, "busy_503": 0, "errors": []}
lock = threading.Lock()
counter = {"next": 0}
rss_warm = {}

def take():
    with lock:
        n = counter["next"]
        if n >= total: return None
        counter["next"] = n + 1
        if n == warmup:
            rss_warm["kib"] = rss_kib()
        return n

def check_frame(kind, headers, data, size):
    if kind in ("render", "encode", "pattern"):
        w, h = size
        if headers.get("x-hdrd-width") != str(w) or headers.get("x-hdrd-height") != str(h):
            return f"{kind}: size headers {headers.get('x-hdrd-width')}x{headers.get('x-hdrd-height')} != {w}x{h}"
        ct = headers.get("content-type", "")
        if ct == "image/png":
            if not data.startswith(PNG_SIG) or struct.unpack(">II", data[16:24]) != (w, h) or not data.endswith(b"IEND\xaeB`\x82"):
                return "render: bad PNG"
        elif ct == "application/octet-stream":
            if len(data) != int(headers["x-hdrd-stride"]) * h:
                return "raw: wrong size"
        elif ct == "image/x-exr":
            if not data.startswith(b"\x76\x2f\x31\x01"):
                return "exr: bad magic"
    elif kind == "dump":
        j = json.loads(data)
        if not j.get("files"): return "dump: no files"
    elif kind == "selftest":
        if not json.loads(data).get("passed"): return "selftest: a check failed"
    return None

def worker(seed):
    rng = random.Random(seed)
    conn = UnixConnection()
    while True:
        n = take()
        if n is None: break
        r = rng.random()
        try:
            if r < 0.03:
                raw_abuse(rng)
                with lock: stats["abuse"] += 1
                continue
            if r < 0.13:
                method, path, body, ctype = malformed_request(rng)
                hdrs = {"Content-Type": ctype} if ctype else {}
                conn.request(method, path, body=body, headers=hdrs)
                resp = conn.getresponse(); resp.read()
                if resp.getheader("Connection", "").lower() == "close":
                    conn.close(); conn = UnixConnection()
                with lock:
                    stats["malformed_sent"] += 1
                    if 400 <= resp.status < 500: stats["malformed_4xx"] += 1
                    else: stats["errors"].append(f"malformed {method} {path} {body[:40] if body else ''} -> {resp.status}")
                continue
            kind, method, path, body, hdrs, size = valid_request(rng)
            conn.request(method, path, body=body, headers=hdrs)
            resp = conn.getresponse(); data = resp.read()
            headers = {k.lower(): v for k, v in resp.getheaders()}
            if resp.status == 503:
                with lock: stats["busy_503"] += 1
                continue
            problem = None if resp.status == 200 else f"{kind} {path} -> {resp.status} {data[:200]!r}"
            problem = problem or check_frame(kind, headers, data, size)
            with lock:
                if problem: stats["errors"].append(problem)
                else: stats["ok"] += 1
        except (OSError, http.client.HTTPException) as e:
            conn.close(); conn = UnixConnection()
            with lock: stats["errors"].append(f"client exception: {e!r}")

load_start = os.getloadavg()
t0 = time.time()
threads = [threading.Thread(target=worker, args=(i,)) for i in range(clients)]
for t in threads: t.start()
for t in threads: t.join()
elapsed = time.time() - t0
time.sleep(0.5)
rss_end = rss_kib()
alive = os.path.exists(f"/proc/{pid}")

# No partial files: only finished dump files (NAME.png/.exr/.raw/.json, no temporaries),
# each complete: PNGs end with IEND, EXRs start with the magic number, raw buffers have a
# whole frame (32x18 at 4 or 8 bytes per pixel), sidecars parse and name existing files.
# (Names are reused on purpose, so a name may keep files of an earlier dump's formats.)
import re
dumps = os.path.join(work, "dumps")
names = sorted(os.listdir(dumps))
partial = []
for n in names:
    path = os.path.join(dumps, n)
    m = re.fullmatch(r"soak-\d+\.(png|exr|raw|json)", n)
    if not m:
        partial.append(n); continue
    d = open(path, "rb").read()
    ext = m.group(1)
    complete = {
        "png": lambda: d.startswith(PNG_SIG) and d.endswith(b"IEND\xaeB`\x82"),
        "exr": lambda: d.startswith(b"\x76\x2f\x31\x01") and len(d) > 300,
        "raw": lambda: len(d) in (32 * 18 * 4, 32 * 18 * 8),
        "json": lambda: all(os.path.exists(os.path.join(dumps, p)) for p in json.loads(d)["files"].values()),
    }[ext]()
    if not complete: partial.append(n)

growth = 100.0 * (rss_end - rss_warm["kib"]) / rss_warm["kib"] if rss_warm.get("kib") else float("nan")
summary = {
    "requests": total, "clients": clients, "seconds": round(elapsed, 1), "requests_per_s": round(total / elapsed, 1),
    "load_average_start": [round(x, 2) for x in load_start], "load_average_end": [round(x, 2) for x in os.getloadavg()],
    "ok": stats["ok"], "malformed_sent": stats["malformed_sent"], "malformed_4xx": stats["malformed_4xx"], "hangups_and_garbage": stats["abuse"],
    "busy_503": stats["busy_503"], "errors": len(stats["errors"]), "daemon_alive": alive,
    "rss_after_warmup_kib": rss_warm.get("kib"), "rss_end_kib": rss_end, "rss_growth_percent": round(growth, 2),
    "dump_files": len(names), "partial_files": partial,
}
print(json.dumps(summary, indent=2))
for e in stats["errors"][:20]: print("  error:", e, file=sys.stderr)
ok = alive and not stats["errors"] and not partial and growth < 5.0
sys.exit(0 if ok else 1)
PY
py_status=$?
set -e

# The daemon must still be alive, then drain and exit 0 on SIGTERM.
if ! kill -0 "$daemon_pid" 2>/dev/null; then
  echo "soak: FAILED: the daemon died" >&2; tail -20 "$work/daemon.log" >&2; exit 1
fi
kill -TERM "$daemon_pid"
set +e
wait "$daemon_pid"
rc=$?
set -e
daemon_pid=""
if [ $rc -ne 0 ]; then echo "soak: FAILED: hdrd exited $rc after SIGTERM" >&2; tail -20 "$work/daemon.log" >&2; exit 1; fi
if [ $py_status -ne 0 ]; then echo "soak: FAILED (see above)" >&2; exit 1; fi
echo "soak: passed (0 crashes, clean SIGTERM exit)"
