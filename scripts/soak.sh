#!/usr/bin/env bash
# Soak of `hdrd serve` under normal load and under abuse, over a temporary Unix socket
# (nothing else is reachable). Stops by itself; not part of ctest (it takes minutes);
# docs/performance-daemon.md has the numbers of the last run.
#
#  1. warm-up: W mixed requests (renders, encodes, patterns, self-tests, dumps, GETs);
#     the RSS at its end is the reference.
#  2. for T seconds, at once:
#     - C clients keep sending the mix (10 % malformed, 3 % hanging up mid-request), and
#       every answer is checked (size headers, PNG/EXR/raw form, sidecars);
#     - abusers cycle through the classes of issue 14: slow headers and slow bodies (one
#       byte a second), connection floods (1500 at once, held), multipart and JSON bodies
#       nested 100 000 deep, a glTF nested 20 000 deep in the asset root, huge base64 UIs
#       (a PNG declaring 16384 x 8192, random bytes at the size limit, a body over it),
#       invalid UTF-8 and NUL in query parameters, symbolic and hard links in the asset
#       root to files that are not EDIDs, a chunk-extension bomb, NUL bytes in bodies,
#       and large frames near the memory budget; and issue 28's: many short connections
#       (40 and 100 clients of one uid, one connection each at a time: every request must
#       get a whole reply), file swaps during jobs (an EXR sequence's last frame replaced
#       after the 202 by a symlink or a hard link to a file outside the asset root, or by a
#       FIFO: the job must not read outside the root, nor hang), name collisions (a job
#       named x.00001 beside a sequence x: x's files must stay), and crash and restart (a
#       second daemon killed with -9 mid-sequence and restarted: no final-named file of
#       the unfinished sequence may stay);
#     - a probe opens a new connection every 250 ms and times GET /v1/status;
#     - the daemon's RSS is sampled every 100 ms.
#  3. the load stops; after 5 s the RSS is read again.
# Checks: no crash (alive, exit 0 on SIGTERM), no 5xx for a client's fault, every probe
# answered and the worst under 1 s, RSS peak within warm-up + the memory budget, RSS
# after within 20 % of the warm-up, every valid answer correct, no partial dump file,
# no dropped request (a connection closed without a reply to a request sent whole: the
# short-connection rounds, and the clients' retries on fresh connections), and no
# FAILED outcome in the issue 28 classes (the summary's "abuse" lists each outcome).
#
# Usage: scripts/soak.sh [-t SECONDS] [-c CLIENTS] [-w WARMUP] [-m BUDGET_MIB] [-b BUILD_DIR]
set -euo pipefail
cd "$(dirname "$0")/.."

seconds=120
clients=3
warmup=300
budget_mib=1536
build_dir=${BUILD_DIR:-build}
while getopts "t:c:w:m:b:h" opt; do
  case $opt in
    t) seconds=$OPTARG ;;
    c) clients=$OPTARG ;;
    w) warmup=$OPTARG ;;
    m) budget_mib=$OPTARG ;;
    b) build_dir=$OPTARG ;;
    *) sed -n '2,37p' "$0"; exit 2 ;;
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
printf 'not an EDID\n' > "$work/assets/notes.txt"
printf 'secret\n' > "$work/outside.txt"
ln -s "$work/assets/notes.txt" "$work/assets/sym.bin"
ln "$work/assets/notes.txt" "$work/assets/hard.bin"
ln -s "$work/outside.txt" "$work/assets/escape.bin"
python3 -c "import sys; d=20000; sys.stdout.write('{\"asset\":{\"version\":\"2.0\"},\"extras\":' + '['*d + ']'*d + '}')" \
  > "$work/assets/deep.gltf"
cat > "$work/hdrd.toml" <<EOF
[server]
socket_path = "$work/hdrd.sock"
[workers]
render_workers = 1
encode_threads = 2
queue_depth = 64
memory_budget_bytes = $((budget_mib << 20))
[paths]
asset_root = "$work/assets"
dump_dir = "$work/dumps"
[limits]
max_upload_bytes = 67108864
max_request_seconds = 120
[log]
level = "warn"
access_log = false
EOF

"$hdrd" serve --config "$work/hdrd.toml" > "$work/daemon.log" 2>&1 &
daemon_pid=$!

set +e
python3 - "$work" "$daemon_pid" "$seconds" "$clients" "$warmup" "$budget_mib" "$hdrd" <<'PY'
import base64, http.client, json, os, random, re, resource, shutil, signal, socket, statistics, struct, subprocess, sys, threading, time

work, pid, seconds, clients, warmup, budget_mib = sys.argv[1], int(sys.argv[2]), float(sys.argv[3]), int(sys.argv[4]), int(sys.argv[5]), int(sys.argv[6])
hdrd_bin = os.path.abspath(sys.argv[7])
sock_path = os.path.join(work, "hdrd.sock")
soft, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
resource.setrlimit(resource.RLIMIT_NOFILE, (hard, hard))

class UnixConnection(http.client.HTTPConnection):
    def __init__(self, timeout=180):
        super().__init__("localhost", timeout=timeout)
        self._t = timeout
    def connect(self):
        s = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        s.settimeout(self._t)
        s.connect(sock_path)
        self.sock = s

def _connect_to(c, path, timeout):
    s = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM); s.settimeout(timeout); s.connect(path); c.sock = s

def rss_kib():
    try:
        with open(f"/proc/{pid}/status") as f:
            for line in f:
                if line.startswith("VmRSS:"):
                    return int(line.split()[1])
    except OSError:
        pass
    return -1

def one(method, path, body=None, headers=None, timeout=180, sock=None):
    c = UnixConnection(timeout)
    if sock: c.connect = lambda: _connect_to(c, sock, timeout)
    try:
        c.request(method, path, body=body, headers=headers or {})
        r = c.getresponse()
        return r.status, dict((k.lower(), v) for k, v in r.getheaders()), r.read()
    finally:
        c.close()

for _ in range(1200):
    try:
        if one("GET", "/v1/status", timeout=5)[0] == 200: break
    except OSError:
        time.sleep(0.05)
else:
    sys.exit("soak: the daemon did not come up")

status = json.loads(one("GET", "/v1/status")[2])
have_renderer = status.get("renderer", {}).get("available", False)
PNG_SIG = b"\x89PNG\r\n\x1a\n"

# Inputs made by the daemon itself: a tiny EXR, and a 1920x1080 one for large uploads.
def exr_of(w, h):
    if have_renderer:
        st, _, data = one("POST", "/v1/render", json.dumps({"width": w, "height": h}), {"Accept": "image/x-exr"})
    else:
        st, _, data = one("POST", "/v1/pattern", json.dumps({"pattern": "pq-ramp", "width": w, "height": h}), {"Accept": "image/x-exr"})
    assert st == 200, st
    return data
exr = exr_of(32, 18)
big_exr = exr_of(1920, 1080)
mid_exr = exr_of(960, 540)  # the frames of the file-swap and crash rounds
with open(os.path.join(work, "outside.exr"), "wb") as f: f.write(mid_exr)  # outside the asset root

def multipart(parts, boundary="hdrdSoakBoundary7"):
    out = b""
    for name, data in parts:
        out += f"--{boundary}\r\nContent-Disposition: form-data; name=\"{name}\"\r\n\r\n".encode() + data + b"\r\n"
    return out + f"--{boundary}--\r\n".encode(), f"multipart/form-data; boundary={boundary}"

modes = ["hdr10", "hlg", "sdr", "sdr-bt1886", "scrgb"]
def valid_request(rng):
    kind = rng.random()
    if kind < 0.50 and have_renderer:
        w, h = rng.choice([(64, 36), (96, 54), (128, 72), (32, 18)])
        mode = rng.choice(modes)
        body = {"width": w, "height": h, "display": {"mode": mode}, "exposure_comp_ev": rng.choice([-1, -0.5, 0, 0.5, 1])}
        if rng.random() < 0.3: body["tone"] = {"curve": rng.choice(["clip", "reinhard", "bt2390"])}
        accept = rng.choice(["image/png", "application/octet-stream", "image/x-exr"])
        if mode == "scrgb" and accept == "image/png": accept = "image/x-exr"
        return ("render", "POST", "/v1/render", json.dumps(body), {"Content-Type": "application/json", "Accept": accept}, (w, h))
    if kind < 0.62:
        w, h = rng.choice([(64, 36), (96, 54), (192, 108)])
        name = rng.choice(["bt2111", "pq-ramp", "window", "near-black", "clipping", "sdr-grey"])
        body = {"pattern": name, "width": w, "height": h, "display": {"mode": rng.choice(["hdr10", "hlg"])}}
        if name == "window":
            body["params"] = {"level_nits": rng.choice([100, 203, 600, 1000]), "area_percent": rng.choice([1, 10, 25])}
        accept = rng.choice(["image/png", "application/octet-stream", "image/x-exr"])
        return ("pattern", "POST", "/v1/pattern", json.dumps(body), {"Content-Type": "application/json", "Accept": accept}, (w, h))
    if kind < 0.625:
        body = {"mode": rng.choice(["hdr10", "hlg", "sdr", "scrgb", "sdr-bt1886"]), "render": have_renderer and rng.random() < 0.5}
        return ("selftest", "POST", "/v1/selftest", json.dumps(body), {"Content-Type": "application/json"}, None)
    if kind < 0.75:
        mode = rng.choice(modes)
        return ("encode", "POST", f"/v1/encode?mode={mode}", exr, {"Content-Type": "image/x-exr", "Accept": "application/octet-stream"}, (32, 18))
    if kind < 0.80:
        options = {"dump": True, "name": f"soak-{rng.randrange(20)}", "formats": rng.choice([["png", "raw"], ["exr"], ["png", "exr", "raw"]])}
        body, ct = multipart([("image", exr), ("request", json.dumps(options).encode())])
        return ("dump", "POST", "/v1/encode", body, {"Content-Type": ct, "Accept": "application/json"}, None)
    path = rng.choice(["/v1/status", "/v1/capabilities", "/v1/displays", "/metrics"])
    return ("get", "GET", path, None, {}, None)

MALFORMED = [
    ("POST", "/v1/render", '{"width":64,', "application/json"),
    ("POST", "/v1/render", '{"width":"64"}', "application/json"),
    ("POST", "/v1/render", '{"widht":64}', "application/json"),
    ("POST", "/v1/render", '{"width":100000000,"height":100000000}', "application/json"),
    ("POST", "/v1/render", '{"gltf":"../../../etc/passwd"}', "application/json"),
    ("POST", "/v1/render", '{"scene_file":"/etc/shadow"}', "application/json"),
    ("POST", "/v1/render", '{"dump":true,"name":"../escape"}', "application/json"),
    ("POST", "/v1/render", "[" * 100 + "]" * 100, "application/json"),
    ("POST", "/v1/render", "{}", "image/png"),
    ("GET", "/v1/render", None, None),
    ("DELETE", "/v1/status", None, None),
    ("POST", "/v1/encode", "not an exr", "image/x-exr"),
    ("POST", "/v1/encode?colour=red", "x", "image/x-exr"),
    ("GET", "/nope", None, None),
    ("POST", "/v1/pattern", '{"pattern":"smpte"}', "application/json"),
    ("POST", "/v1/pattern", '{"pattern":"window","params":{"level":5}}', "application/json"),
    ("POST", "/v1/selftest", '{"mode":"hdr12"}', "application/json"),
    ("POST", "/v1/render", '{"display":{"peak_nits":5e551}}', "application/json"),
]

lock = threading.Lock()
stats = {"ok": 0, "reconnects": 0, "retries_after_reconnect": 0, "short_requests": 0, "short_dropped": 0, "short_busy": 0, "malformed_sent": 0, "malformed_4xx": 0, "hangups": 0, "shed_503": 0, "errors": [],
         "abuse": {}, "client_fault_5xx": [], "probe": [], "probe_failures": 0, "rss_peak_kib": 0}
def note_abuse(cls, outcome):
    with lock:
        d = stats["abuse"].setdefault(cls, {})
        d[outcome] = d.get(outcome, 0) + 1

def check_frame(kind, headers, data, size):
    if kind in ("render", "encode", "pattern"):
        w, h = size
        if headers.get("x-hdrd-width") != str(w) or headers.get("x-hdrd-height") != str(h):
            return f"{kind}: size headers {headers.get('x-hdrd-width')}x{headers.get('x-hdrd-height')} != {w}x{h}"
        ct = headers.get("content-type", "")
        if ct == "image/png":
            if not data.startswith(PNG_SIG) or struct.unpack(">II", data[16:24]) != (w, h) or not data.endswith(b"IEND\xaeB`\x82"):
                return f"{kind}: bad PNG"
        elif ct == "application/octet-stream":
            if len(data) != int(headers["x-hdrd-stride"]) * h: return f"{kind}: raw of the wrong size"
        elif ct == "image/x-exr":
            if not data.startswith(b"\x76\x2f\x31\x01"): return f"{kind}: bad EXR magic"
    elif kind == "dump":
        if not json.loads(data).get("files"): return "dump: no files"
    elif kind == "selftest":
        if not json.loads(data).get("passed"): return "selftest: a check failed"
    return None

phase = {"abuse": False, "stop": False, "count": 0}

def worker(seed, limit=None):
    rng = random.Random(seed)
    conn = UnixConnection()
    while not phase["stop"]:
        with lock:
            if limit is not None and phase["count"] >= limit: break
            phase["count"] += 1
        r = rng.random()
        try:
            if r < 0.03:
                s = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM); s.settimeout(5); s.connect(sock_path)
                if have_renderer and rng.random() < 0.5:
                    body = json.dumps({"width": 256, "height": 144, "exposure_comp_ev": rng.random()})
                    s.sendall(f"POST /v1/render HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\nContent-Length: {len(body)}\r\n\r\n{body}".encode())
                    time.sleep(rng.random() * 0.05)
                else:
                    s.sendall(b"POST /v1/encode HTTP/1.1\r\nHost: x\r\nContent-Length: 500\r\n\r\nv/1")
                s.close()
                with lock: stats["hangups"] += 1
                continue
            if r < 0.13:
                method, path, body, ctype = rng.choice(MALFORMED)
                try:
                    conn.request(method, path, body=body, headers={"Content-Type": ctype} if ctype else {})
                    resp = conn.getresponse(); resp.read()
                except (http.client.RemoteDisconnected, BrokenPipeError, ConnectionResetError):
                    conn.close(); conn = UnixConnection()
                    with lock: stats["reconnects"] += 1
                    conn.request(method, path, body=body, headers={"Content-Type": ctype} if ctype else {})
                    resp = conn.getresponse(); resp.read()
                if resp.getheader("Connection", "").lower() == "close": conn.close(); conn = UnixConnection()
                with lock:
                    stats["malformed_sent"] += 1
                    if 400 <= resp.status < 500: stats["malformed_4xx"] += 1
                    else: stats["client_fault_5xx" if resp.status >= 500 else "errors"].append(f"malformed {method} {path} {(body or '')[:40]!r} -> {resp.status}")
                continue
            kind, method, path, body, hdrs, size = valid_request(rng)
            try:
                conn.request(method, path, body=body, headers=hdrs)
                resp = conn.getresponse(); data = resp.read()
            except (http.client.RemoteDisconnected, BrokenPipeError, ConnectionResetError):
                # The daemon may close an idle keep-alive connection (header deadline, or to
                # make room during a flood); clients retry once on a new one, as
                # hdrd_client.py and daemon::Client do. A fresh connection closed before
                # its reply is a dropped request (retries_after_reconnect, which fails the
                # soak); such a client tries again after a pause, up to three times.
                for attempt in range(3):
                    conn.close(); conn = UnixConnection()
                    with lock: stats["reconnects"] += 1
                    try:
                        conn.request(method, path, body=body, headers=hdrs)
                        resp = conn.getresponse(); data = resp.read()
                        break
                    except (http.client.RemoteDisconnected, BrokenPipeError, ConnectionResetError):
                        if attempt == 2: raise
                        with lock: stats["retries_after_reconnect"] += 1
                        time.sleep(0.1 * (attempt + 1))
            headers = {k.lower(): v for k, v in resp.getheaders()}
            if resp.getheader("Connection", "").lower() == "close": conn.close(); conn = UnixConnection()
            if resp.status == 503:
                with lock: stats["shed_503"] += 1
                continue
            problem = None if resp.status == 200 else f"{kind} {path} -> {resp.status} {data[:200]!r}"
            problem = problem or check_frame(kind, headers, data, size)
            with lock:
                if problem: stats["errors"].append(problem)
                else: stats["ok"] += 1
        except (OSError, http.client.HTTPException) as e:
            conn.close(); conn = UnixConnection()
            with lock: stats["errors"].append(f"client exception: {e!r}")

# ---- abuse classes: each returns after one round; outcome codes are counted -------------

def expect(cls, st, body, want):
    code = ""
    try: code = json.loads(body)["error"]["code"]
    except Exception: pass
    if st >= 500 and st not in want:
        with lock: stats["client_fault_5xx"].append(f"{cls} -> {st} {code or body[:80]!r}")
    note_abuse(cls, f"{st} {code}" if st in want else f"UNEXPECTED {st} {code}")

def raw_exchange(data, timeout=15):
    s = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM); s.settimeout(timeout); s.connect(sock_path)
    try:
        try: s.sendall(data)
        except OSError: pass
        out = b""
        while True:
            try: b = s.recv(65536)
            except OSError: break
            if not b: break
            out += b
        return out
    finally: s.close()

def status_of(raw):
    m = re.match(rb"HTTP/1\.1 (\d{3})", raw)
    return (int(m.group(1)) if m else 0), raw.split(b"\r\n\r\n", 1)[-1]

def slow(cls, header_only):
    """16 connections sending one byte a second, until the daemon closes them."""
    req = (b"GET /v1/status HTTP/1.1\r\nHost: x\r\nX-Pad: " + b"p" * 200 + b"\r\n\r\n") if header_only else \
          (b"POST /v1/encode HTTP/1.1\r\nHost: x\r\nContent-Type: image/x-exr\r\nContent-Length: 100000\r\n\r\n" + b"v" * 200)
    start = 0 if header_only else req.index(b"\r\n\r\n") + 4
    socks = []
    for _ in range(16):
        s = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM); s.connect(sock_path); s.setblocking(False)
        if start: s.sendall(req[:start])
        socks.append(s)
    t0 = time.time(); i = start; open_ = set(range(len(socks))); held = []
    while open_ and not phase["stop"] and i < len(req):
        for k in list(open_):
            try:
                socks[k].send(req[i:i + 1])
                if socks[k].recv(4096, socket.MSG_PEEK) == b"": raise OSError
            except BlockingIOError: pass
            except OSError:
                open_.discard(k); held.append(time.time() - t0)
        i += 1; time.sleep(1.0)
    for k, s in enumerate(socks):
        if k in open_: note_abuse(cls, "still open when the round ended")
        s.close()
    for h in held: note_abuse(cls, "closed within 13 s" if h < 13 else f"held {h:.0f} s")

def flood(cls):
    socks = []
    for _ in range(1500):
        try:
            s = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM); s.settimeout(2); s.connect(sock_path); socks.append(s)
        except OSError: note_abuse(cls, "connect refused"); break
    time.sleep(3)
    for s in socks: s.close()
    note_abuse(cls, f"{len(socks)} opened and held 3 s")

def png_declaring(w, h):
    import zlib
    def chunk(t, d): return struct.pack(">I", len(d)) + t + d + struct.pack(">I", zlib.crc32(t + d) & 0xffffffff)
    return PNG_SIG + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 6, 0, 0, 0)) + chunk(b"IDAT", zlib.compress(b"\0" * 64)) + chunk(b"IEND", b"")

# ---- issue 28 classes -------------------------------------------------------------------

def short_exchange(sock=None):
    """One GET /v1/status on a fresh connection, read by its Content-Length, then closed
    (as curl does). Returns the status, or None when the connection closed first."""
    s = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM); s.settimeout(30)
    try:
        s.connect(sock or sock_path)
        s.sendall(b"GET /v1/status HTTP/1.1\r\nHost: x\r\n\r\n")
        out = b""; want = None
        while want is None or len(out) < want:
            b = s.recv(65536)
            if not b: return None
            out += b
            if want is None and b"\r\n\r\n" in out:
                head = out.split(b"\r\n\r\n", 1)[0]
                m = re.search(rb"Content-Length: (\d+)", head)
                want = len(head) + 4 + (int(m.group(1)) if m else 0)
        return int(out[9:12])
    except OSError:
        return None
    finally: s.close()

def short_connections(n_clients, per_client):
    tally = {"dropped": 0, "busy": 0, "ok": 0, "other": 0}
    def client():
        for _ in range(per_client):
            if phase["stop"]: return
            st = short_exchange()
            with lock:
                tally["dropped" if st is None else "ok" if st == 200 else "busy" if st == 503 else "other"] += 1
    ts = [threading.Thread(target=client) for _ in range(n_clients)]
    for t in ts: t.start()
    for t in ts: t.join()
    with lock:
        stats["short_requests"] += sum(tally.values()); stats["short_dropped"] += tally["dropped"]; stats["short_busy"] += tally["busy"]
    cls = f"short connections ({n_clients} clients)"
    note_abuse(cls, "FAILED: dropped requests" if tally["dropped"] else "every request answered")
    if tally["other"]: note_abuse(cls, f"UNEXPECTED status ({tally['other']})")

def post_json(path, body, sock=None):
    st, _, b = one("POST", path, json.dumps(body), {"Content-Type": "application/json"}, timeout=30, sock=sock)
    try: return st, json.loads(b)
    except ValueError: return st, {}

def job_state(job_id, sock=None):
    st, _, b = one("GET", f"/v1/jobs/{job_id}", timeout=10, sock=sock)
    return json.loads(b) if st == 200 else {"state": f"http {st}"}

def wait_job(job_id, limit_s, sock=None, until=("done", "failed", "cancelled")):
    end = time.time() + limit_s
    while time.time() < end:
        j = job_state(job_id, sock)
        if j.get("state") in until: return j
        time.sleep(0.05)
    return None

def make_frames(dirname, count):
    d = os.path.join(work, "assets", dirname)
    shutil.rmtree(d, ignore_errors=True); os.makedirs(d)
    for i in range(1, count + 1):
        with open(os.path.join(d, f"f.{i:05d}.exr"), "wb") as f: f.write(mid_exr)
    return d

swap_counter = [0]
def file_swap(rng):
    """An EXR sequence's last frame replaced after the 202. The outside file is a valid EXR
    of the same size, so a job that reads it succeeds: done means it read outside the root."""
    with lock: swap_counter[0] += 1; n = swap_counter[0]
    kind = ("symlink", "fifo", "hard link")[n % 3]
    cls = f"file swap during a job ({kind})"
    frames = 24
    d = make_frames(f"swap{n}", frames)
    last = os.path.join(d, f"f.{frames:05d}.exr")
    st, j = post_json("/v1/sequences", {"images": f"swap{n}/f.%05d.exr", "fps": 25, "display": {"mode": "hdr10"},
                                         "formats": ["png"], "name": f"swap{n}"})
    if st != 202:
        note_abuse(cls, f"not admitted: {st} {j.get('error', {}).get('code', '')}"); shutil.rmtree(d, ignore_errors=True); return
    os.unlink(last)
    if kind == "symlink": os.symlink(os.path.join(work, "outside.exr"), last)
    elif kind == "hard link": os.link(os.path.join(work, "outside.exr"), last)
    else: os.mkfifo(last)
    done = wait_job(j["id"], 30)
    if done is None:
        t0 = time.time()
        try: st_del = one("DELETE", f"/v1/jobs/{j['id']}", timeout=10)[0]
        except (OSError, http.client.HTTPException): st_del = "no answer in 10 s"
        note_abuse(cls, f"FAILED: hung (DELETE: {st_del})")
        if kind == "fifo":  # unblock the reader so the soak can go on
            try:
                fd = os.open(last, os.O_WRONLY | os.O_NONBLOCK); os.close(fd)
            except OSError: pass
        wait_job(j["id"], 60)
    elif done["state"] == "done":
        note_abuse(cls, "FAILED: read outside the root" if kind != "fifo" else "done (the FIFO was read?)")
        one("DELETE", f"/v1/jobs/{j['id']}", timeout=30)
    else:
        err = done.get("error") or {}
        note_abuse(cls, f"refused: job {done['state']} {err.get('code', '')}")
    shutil.rmtree(d, ignore_errors=True)

collision_counter = [0]
def name_collision(rng):
    """A job named x.00001 beside a finished sequence x: x's files must stay as they were."""
    with lock: collision_counter[0] += 1; n = collision_counter[0]
    cls = "name collision (x.00001 beside x)"
    d = make_frames(f"clash{n}", 2)
    name = f"clash{n}"
    st, j = post_json("/v1/sequences", {"images": f"clash{n}/f.%05d.exr", "fps": 25, "display": {"mode": "hdr10"},
                                         "formats": ["png"], "name": name})
    if st != 202:
        note_abuse(cls, f"not admitted: {st}"); shutil.rmtree(d, ignore_errors=True); return
    done = wait_job(j["id"], 60)
    if not done or done["state"] != "done":
        note_abuse(cls, f"the first job did not finish: {done and done.get('state')}"); shutil.rmtree(d, ignore_errors=True); return
    dumps = os.path.join(work, "dumps")
    def owned():
        return {f: open(os.path.join(dumps, f), "rb").read() for f in os.listdir(dumps)
                if re.fullmatch(re.escape(name) + r"(\.\d{5})?\.(png|json)", f)}
    before = owned()
    outcomes = []
    st2, j2 = post_json("/v1/sequences", {"images": f"clash{n}/f.%05d.exr", "frames": 1, "fps": 25,
                                           "display": {"mode": "hdr10"}, "formats": ["png"], "name": f"{name}.00001"})
    if st2 == 202:
        wait_job(j2["id"], 60)
        one("DELETE", f"/v1/jobs/{j2['id']}", timeout=30)
        outcomes.append("sequence accepted")
    else:
        outcomes.append(f"sequence refused {st2} {j2.get('error', {}).get('code', '')}")
    body, ct = multipart([("image", exr), ("request", json.dumps({"dump": True, "name": f"{name}.00001", "formats": ["png"]}).encode())])
    st3, _, b3 = one("POST", "/v1/encode", body, {"Content-Type": ct, "Accept": "application/json"}, timeout=30)
    outcomes.append("dump accepted" if st3 == 200 else f"dump refused {st3}")
    after = owned()
    state = job_state(j["id"]).get("state")
    if any(after.get(f) != v for f, v in before.items()):
        note_abuse(cls, f"FAILED: x's files changed or removed ({'; '.join(outcomes)}; x is {state})")
    else:
        note_abuse(cls, f"x's files intact ({'; '.join(outcomes)})")
    one("DELETE", f"/v1/jobs/{j['id']}", timeout=30)
    for f in os.listdir(dumps):
        if f.startswith(name + "."): os.unlink(os.path.join(dumps, f))
    shutil.rmtree(d, ignore_errors=True)

crash_lock = threading.Lock()
def crash_restart(rng):
    """A second daemon (own socket and dump directory, the same asset root) killed with -9
    in the middle of a sequence, then restarted: what final-named files of that sequence
    (NAME.NNNNN.EXT, NAME.json, the video) are left once it is up again."""
    cls = "crash and restart (kill -9 mid-sequence)"
    with crash_lock:
        base = os.path.join(work, "crash")
        os.makedirs(os.path.join(base, "dumps"), exist_ok=True)
        sock = os.path.join(base, "hdrd.sock")
        with open(os.path.join(base, "hdrd.toml"), "w") as f:
            f.write(f'[server]\nsocket_path = "{sock}"\n[paths]\nasset_root = "{work}/assets"\ndump_dir = "{base}/dumps"\n'
                    '[log]\nlevel = "warn"\naccess_log = false\n')
        def start():
            p = subprocess.Popen([hdrd_bin, "serve", "--config", os.path.join(base, "hdrd.toml")],
                                 stdout=open(os.path.join(base, "daemon.log"), "ab"), stderr=subprocess.STDOUT)
            for _ in range(600):
                if short_exchange(sock) == 200: return p
                time.sleep(0.05)
            p.kill(); p.wait(); return None
        p = start()
        if not p: note_abuse(cls, "FAILED: the second daemon did not come up"); return
        d = make_frames("crashframes", 60)
        name = f"crash{rng.randrange(1 << 30)}"
        try:
            st, j = post_json("/v1/sequences", {"images": "crashframes/f.%05d.exr", "fps": 25, "display": {"mode": "hdr10"},
                                                 "formats": ["png", "exr"], "name": name}, sock=sock)
            if st != 202:
                note_abuse(cls, f"not admitted: {st}"); return
            end = time.time() + 60
            while time.time() < end and job_state(j["id"], sock).get("frames_done", 0) < 5: time.sleep(0.02)
            p.send_signal(signal.SIGKILL); p.wait()
            p = start()
            if not p: note_abuse(cls, "FAILED: the daemon did not come back after kill -9"); return
            left = [f for f in os.listdir(os.path.join(base, "dumps")) if f.startswith(name + ".")]
            final = [f for f in left if ".tmp-" not in f]
            with lock: stats.setdefault("crash_leftovers", []).append(len(final))
            note_abuse(cls, f"FAILED: final-named files left after restart" if final else "nothing final-named left")
            if len(left) > len(final): note_abuse(cls, "FAILED: temporary files left after restart")
        finally:
            if p:
                p.terminate()
                try: p.wait(30)
                except subprocess.TimeoutExpired: p.kill(); p.wait(); note_abuse(cls, "FAILED: no exit within 30 s of SIGTERM")
            shutil.rmtree(os.path.join(base, "dumps"), ignore_errors=True)
            shutil.rmtree(d, ignore_errors=True)

def abuse_round(rng, k):
    cls = k % 18
    if cls == 0: slow("slow headers", True)
    elif cls == 1: slow("slow bodies", False)
    elif cls == 2: flood("connection flood")
    elif cls == 3:
        body, ct = multipart([("image", exr), ("request", b"[" * 100000 + b"]" * 100000)])
        st, _, b = one("POST", "/v1/encode", body, {"Content-Type": ct}); expect("multipart deep JSON", st, b, {400})
    elif cls == 4:
        st, _, b = one("POST", "/v1/render", "[" * 100000 + "]" * 100000, {"Content-Type": "application/json"}); expect("deep JSON body", st, b, {400})
    elif cls == 5 and have_renderer:
        st, _, b = one("POST", "/v1/render", json.dumps({"scene": "deep.gltf", "width": 32, "height": 18}), {"Content-Type": "application/json"})
        expect("deep glTF in the asset root", st, b, {422})
    elif cls == 6:
        png = base64.b64encode(png_declaring(16384, 8192)).decode()
        body, ct = multipart([("image", exr), ("request", json.dumps({"ui": {"png_base64": png}}).encode())])
        st, _, b = one("POST", "/v1/encode", body, {"Content-Type": ct}); expect("base64 PNG declaring 16384x8192", st, b, {400})
        junk = base64.b64encode(os.urandom(6 << 20)).decode()
        body, ct = multipart([("image", exr), ("request", json.dumps({"ui": {"png_base64": junk}}).encode())])
        st, _, b = one("POST", "/v1/encode", body, {"Content-Type": ct}); expect("6 MiB of random base64", st, b, {400, 413, 422})
        st, _, b = one("POST", "/v1/render", json.dumps({"ui": {"png_base64": "A" * (17 << 20)}}), {"Content-Type": "application/json"})
        expect("base64 body over the limit", st, b, {413})
    elif cls == 7:
        p = rng.choice(["mode", "peak_nits", "curve", "name", "exposure", "dump", "bits", "gamut"])
        v = rng.choice(["%ff", "%c0%af", "hdr10%00", "%ed%a0%80", "%fe%ff"])
        st, _, b = one("POST", f"/v1/encode?{p}={v}", exr, {"Content-Type": "image/x-exr"}); expect("invalid UTF-8 / NUL in a query", st, b, {400})
    elif cls == 8:
        for name, want in (("sym.bin", {422}), ("hard.bin", {422}), ("escape.bin", {403})):
            body, ct = multipart([("image", exr), ("request", json.dumps({"display": {"edid": name}}).encode())])
            st, _, b = one("POST", "/v1/encode", body, {"Content-Type": ct}); expect(f"link in the asset root ({name})", st, b, want)
    elif cls == 9:
        st, b = status_of(raw_exchange(b"POST /v1/encode HTTP/1.1\r\nHost: x\r\nContent-Type: image/x-exr\r\nTransfer-Encoding: chunked\r\n\r\n1;" + b"a" * 300000))
        expect("chunk-extension bomb", st, b, {411})
    elif cls == 10:
        st, _, b = one("POST", "/v1/render", b'{"width":64}\0garbage', {"Content-Type": "application/json"}); expect("NUL in a JSON body", st, b, {400})
    elif cls in (11, 12):
        # Large valid frames, near the budget: answered, or shed with 503 queue.* (not a fault).
        if have_renderer and cls == 11:
            st, _, b = one("POST", "/v1/render", json.dumps({"width": 1920, "height": 1080, "samples": 4}), {"Content-Type": "application/json", "Accept": "image/x-exr"})
        else:
            st, _, b = one("POST", "/v1/encode?mode=hdr10", big_exr, {"Content-Type": "image/x-exr", "Accept": "image/x-exr"})
        if st == 503:
            code = json.loads(b)["error"]["code"]
            note_abuse("large frames", f"503 {code}")
            if not code.startswith("queue."):
                with lock: stats["errors"].append(f"large frame -> 503 {code}")
        else:
            note_abuse("large frames", str(st))
            if st != 200:
                with lock: stats["errors"].append(f"large frame -> {st} {b[:120]!r}")
    elif cls == 13:
        st, _, b = one("GET", "/v1/status?x=%ff"); expect("invalid UTF-8 in a GET query", st, b, {400})
    elif cls == 14: short_connections(40 if (k // 18) % 2 == 0 else 100, 25)
    elif cls == 15: file_swap(rng)
    elif cls == 16: name_collision(rng)
    elif cls == 17: crash_restart(rng)

def abuser(seed):
    rng = random.Random(seed); k = seed
    while not phase["stop"]:
        try: abuse_round(rng, k)
        except (OSError, http.client.HTTPException) as e:
            note_abuse("client-side exception", type(e).__name__)
        k += 3

def prober():
    while not phase["stop"]:
        t0 = time.time()
        try:
            st = one("GET", "/v1/status", timeout=5)[0]
            ok = st == 200
        except (OSError, http.client.HTTPException):
            ok = False
        dt = time.time() - t0
        with lock:
            if phase["abuse"]: stats["probe"].append(dt)
            if not ok and phase["abuse"]: stats["probe_failures"] += 1
        time.sleep(max(0.0, 0.25 - dt))

def sampler():
    while not phase["stop"]:
        r = rss_kib()
        with lock: stats["rss_peak_kib"] = max(stats["rss_peak_kib"], r)
        time.sleep(0.1)

# ---- 1. warm-up -----------------------------------------------------------------------
t_start = time.time()
ws = [threading.Thread(target=worker, args=(i, warmup)) for i in range(clients)]
for t in ws: t.start()
for t in ws: t.join()
time.sleep(1.0)
rss_warm = rss_kib()
stats["rss_peak_kib"] = rss_warm

# ---- 2. load and abuse ----------------------------------------------------------------
phase["abuse"] = True
threads = [threading.Thread(target=sampler), threading.Thread(target=prober)]
threads += [threading.Thread(target=worker, args=(1000 + i,)) for i in range(clients)]
threads += [threading.Thread(target=abuser, args=(i,)) for i in range(3)]
load_start = os.getloadavg()
t0 = time.time()
for t in threads: t.start()
time.sleep(seconds)
phase["stop"] = True
for t in threads: t.join()
elapsed = time.time() - t0

# ---- 3. after the burst -----------------------------------------------------------------
time.sleep(5.0)
rss_after = rss_kib()
alive = os.path.exists(f"/proc/{pid}")

# No partial files: finished dump files only (NAME.png/.exr/.raw/.json), each complete.
dumps = os.path.join(work, "dumps")
names = sorted(os.listdir(dumps))
partial = []
for n in names:
    if re.fullmatch(r"(swap|clash)\d+.*", n): continue  # issue 28 rounds; their outcomes are in "abuse"
    m = re.fullmatch(r"soak-\d+\.(png|exr|raw|json)", n)
    if not m: partial.append(n); continue
    d = open(os.path.join(dumps, n), "rb").read()
    complete = {"png": lambda: d.startswith(PNG_SIG) and d.endswith(b"IEND\xaeB`\x82"),
                "exr": lambda: d.startswith(b"\x76\x2f\x31\x01") and len(d) > 300,
                "raw": lambda: len(d) in (32 * 18 * 4, 32 * 18 * 8),
                "json": lambda: all(os.path.exists(os.path.join(dumps, p)) for p in json.loads(d)["files"].values())}[m.group(1)]()
    if not complete: partial.append(n)

probe = sorted(stats["probe"])
budget_kib = budget_mib * 1024
summary = {
    "abuse_seconds": round(elapsed, 1), "clients": clients, "renderer": have_renderer,
    "load_average_start": [round(x, 2) for x in load_start], "load_average_end": [round(x, 2) for x in os.getloadavg()],
    "valid_ok": stats["ok"], "malformed_sent": stats["malformed_sent"], "malformed_4xx": stats["malformed_4xx"],
    "hangups": stats["hangups"], "shed_503": stats["shed_503"], "reconnects": stats["reconnects"], "retries_after_reconnect": stats["retries_after_reconnect"],
    "errors": len(stats["errors"]),
    "dropped_requests": stats["short_dropped"] + stats["retries_after_reconnect"],
    "short_connection_requests": stats["short_requests"], "short_connection_dropped": stats["short_dropped"],
    "short_connection_503": stats["short_busy"], "crash_final_named_leftovers": stats.get("crash_leftovers", []),
    "client_fault_5xx": len(stats["client_fault_5xx"]), "abuse": stats["abuse"],
    "probes": len(probe), "probe_failures": stats["probe_failures"],
    "probe_median_ms": round(1e3 * statistics.median(probe), 1) if probe else None,
    "probe_p99_ms": round(1e3 * probe[int(0.99 * (len(probe) - 1))], 1) if probe else None,
    "probe_worst_ms": round(1e3 * probe[-1], 1) if probe else None,
    "daemon_alive": alive, "memory_budget_mib": budget_mib,
    "rss_warm_kib": rss_warm, "rss_peak_kib": stats["rss_peak_kib"], "rss_after_kib": rss_after,
    "rss_peak_over_warm_mib": round((stats["rss_peak_kib"] - rss_warm) / 1024, 1),
    "rss_after_vs_warm_percent": round(100.0 * (rss_after - rss_warm) / rss_warm, 1),
    "dump_files": len(names), "partial_files": partial,
}
print(json.dumps(summary, indent=2))
for e in (stats["errors"] + stats["client_fault_5xx"])[:30]: print("  problem:", e, file=sys.stderr)
ok = (alive and not stats["errors"] and not stats["client_fault_5xx"] and not partial and probe and
      summary["dropped_requests"] == 0 and
      all(not k.startswith("FAILED") for d in stats["abuse"].values() for k in d) and
      stats["probe_failures"] == 0 and probe[-1] < 1.0 and
      stats["rss_peak_kib"] - rss_warm <= budget_kib and rss_after <= 1.2 * rss_warm and
      all(not k.startswith("UNEXPECTED") for d in stats["abuse"].values() for k in d))
sys.exit(0 if ok else 1)
PY
py_status=$?
set -e

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
if [ $py_status -ne 0 ]; then echo "soak: FAILED (see above)" >&2; tail -5 "$work/daemon.log" >&2; exit 1; fi
echo "soak: passed (0 crashes, 0 5xx for client faults, clean SIGTERM exit)"
