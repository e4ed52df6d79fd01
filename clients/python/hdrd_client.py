"""Client for the hdrd daemon's HTTP API (docs/api.md), standard library only.

    from hdrd_client import HdrdClient
    c = HdrdClient()                      # $HDRD_SOCKET, $XDG_RUNTIME_DIR/hdrd.sock, /run/hdrd/hdrd.sock
    frame = c.render({"width": 256, "height": 144, "display": {"mode": "hdr10", "peak_nits": 1000}})
    open("frame.png", "wb").write(frame.data)
    print(frame.metadata["maxcll"], frame.metadata["fourcc"])
    bars = c.pattern("bt2111", display={"mode": "hlg"})       # ITU-R BT.2111-2 colour bars
    print(c.selftest("hdr10", peak_nits=1000)["passed"])
    job = c.submit_sequence({"scene": "hdr", "frames": 48, "video": {"codec": "hevc"}})
    c.wait(job["id"], progress=lambda j: print(j["frames_done"], "/", j["frames_total"]))
    c.result(job["id"], "walk.mp4")                           # the video, streamed to the file

Errors from the daemon raise HdrdError with .status, .code, .message and .field.
"""

import http.client
import json
import os
import shutil
import socket
import time
import uuid

# The package version: hdrd's (CMakeLists.txt project(); tests/package checks they agree).
__version__ = "0.1.0"

__all__ = ["HdrdClient", "HdrdError", "JobFailed", "Frame", "default_socket"]


def default_socket():
    """$HDRD_SOCKET, else $XDG_RUNTIME_DIR/hdrd.sock, else /run/hdrd/hdrd.sock."""
    if os.environ.get("HDRD_SOCKET"):
        return os.environ["HDRD_SOCKET"]
    if os.environ.get("XDG_RUNTIME_DIR"):
        return os.path.join(os.environ["XDG_RUNTIME_DIR"], "hdrd.sock")
    return "/run/hdrd/hdrd.sock"


class HdrdError(Exception):
    """An error answer: {"error": {"code", "message", "field"}} with its HTTP status."""

    def __init__(self, status, code, message, field=""):
        super().__init__(f"{message} ({code}, HTTP {status})")
        self.status = status
        self.code = code
        self.message = message
        self.field = field


class JobFailed(Exception):
    """wait() on a job that ended failed or cancelled: .job is its final state (a dict)."""

    def __init__(self, job):
        err = job.get("error") or {}
        super().__init__(f"job {job.get('id')} {job.get('state')}: {err.get('message', 'no reason given')}"
                         f" ({err.get('code', '')})")
        self.job = job


FINAL_STATES = ("done", "failed", "cancelled")


class Frame:
    """An encoded frame: the bytes, their media type and the X-Hdrd-* metadata
    (keys lower-cased without the prefix: mode, fourcc, width, height, stride, maxcll, ...)."""

    def __init__(self, data, content_type, metadata):
        self.data = data
        self.content_type = content_type
        self.metadata = metadata

    def __repr__(self):
        m = self.metadata
        return (f"Frame({m.get('mode')} {m.get('width')}x{m.get('height')} {m.get('fourcc')}, "
                f"{self.content_type}, {len(self.data)} bytes)")


class _UnixConnection(http.client.HTTPConnection):
    def __init__(self, path, timeout):
        super().__init__("localhost", timeout=timeout)
        self._path = path

    def connect(self):
        s = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        s.settimeout(self.timeout)
        s.connect(self._path)
        self.sock = s


class HdrdClient:
    """One client, one (kept-alive) connection. Not thread-safe: use one per thread."""

    def __init__(self, socket_path=None, tcp=None, token=None, timeout=300.0):
        self.socket_path = socket_path or default_socket()
        self.tcp = tcp          # "host:port" instead of the Unix socket
        self.token = token      # bearer token, required over TCP
        self.timeout = timeout
        self._conn = None

    # -- plumbing ------------------------------------------------------------------------
    def _connection(self):
        if self._conn is None:
            if self.tcp:
                host, port = self.tcp.rsplit(":", 1)
                self._conn = http.client.HTTPConnection(host.strip("[]"), int(port), timeout=self.timeout)
            else:
                self._conn = _UnixConnection(self.socket_path, self.timeout)
        return self._conn

    def close(self):
        if self._conn is not None:
            self._conn.close()
            self._conn = None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def request(self, method, path, body=None, headers=None):
        """Sends one request; returns (status, headers dict lower-cased, body bytes)."""
        headers = dict(headers or {})
        if self.token:
            headers["Authorization"] = "Bearer " + self.token
        for attempt in (0, 1):
            conn = self._connection()
            try:
                conn.request(method, path, body=body, headers=headers)
                resp = conn.getresponse()
                data = resp.read()
                hdrs = {k.lower(): v for k, v in resp.getheaders()}
                if hdrs.get("connection", "").lower() == "close":
                    self.close()
                return resp.status, hdrs, data
            except (http.client.RemoteDisconnected, BrokenPipeError, ConnectionResetError):
                self.close()  # the daemon closed an idle kept-alive connection: retry once
                if attempt:
                    raise
        raise RuntimeError("unreachable")

    @staticmethod
    def _raise_for(status, data):
        if status < 400:
            return
        try:
            err = json.loads(data)["error"]
            raise HdrdError(status, err.get("code", ""), err.get("message", ""), err.get("field", ""))
        except (ValueError, KeyError, TypeError):
            raise HdrdError(status, f"http.{status}", data[:200].decode("utf-8", "replace")) from None

    def _get_json(self, path):
        status, _, data = self.request("GET", path)
        self._raise_for(status, data)
        return json.loads(data)

    @staticmethod
    def _frame(headers, data):
        meta = {k[len("x-hdrd-"):]: v for k, v in headers.items() if k.startswith("x-hdrd-")}
        return Frame(data, headers.get("content-type", ""), meta)

    # -- the API ------------------------------------------------------------------------
    def status(self):
        """GET /v1/status: version, uptime, renderer (backend, GL_RENDERER), queue, workers."""
        return self._get_json("/v1/status")

    def capabilities(self):
        """GET /v1/capabilities: modes, tone curves with parameters, limits."""
        return self._get_json("/v1/capabilities")

    def displays(self):
        """GET /v1/displays: connectors, EDID-derived profiles, the auto choice."""
        return self._get_json("/v1/displays")

    def metrics(self):
        """GET /metrics: Prometheus text."""
        status, _, data = self.request("GET", "/metrics")
        self._raise_for(status, data)
        return data.decode()

    def _answer(self, path, body, content_type, dump, accept):
        status, headers, data = self.request(
            "POST", path, body, {"Content-Type": content_type, "Accept": "application/json" if dump else accept})
        self._raise_for(status, data)
        return json.loads(data) if dump else self._frame(headers, data)

    def render(self, request, accept="image/png"):
        """POST /v1/render. `request` is the JSON body (a dict: the settings of
        docs/settings.md, e.g. {"width": 256, "display": {"mode": "hdr10"}}); `accept` picks
        image/png, image/x-exr or application/octet-stream (raw DRM buffer). With
        "dump": true the daemon writes the files into its dump directory and this returns
        the sidecar (paths under "files")."""
        return self._answer("/v1/render", json.dumps(request), "application/json", request.get("dump"), accept)

    def render_dump(self, request):
        """POST /v1/render with "dump": true: returns the sidecar."""
        return self.render(dict(request, dump=True))

    def pattern(self, pattern, params=None, display=None, accept="image/png", **fields):
        """POST /v1/pattern: a standard test pattern (bt2111, pq-ramp, window, near-black,
        clipping, sdr-grey; capabilities()["patterns"] lists them with their parameters).
        `params` holds the pattern's parameters ({"level_nits": 1000, "area_percent": 10}),
        `display` the display target as for render; other request fields (width, height,
        dump, name, formats) as keyword arguments."""
        body = {"pattern": pattern, **fields}
        if params:
            body["params"] = params
        if display is not None:
            body["display"] = display
        return self._answer("/v1/pattern", json.dumps(body), "application/json", body.get("dump"), accept)

    def selftest(self, mode="hdr10", peak_nits=None, render=True):
        """POST /v1/selftest: the display-mode suite for one mode. Returns the report (a dict);
        report["passed"] is False when a check failed (the HTTP status is still 200)."""
        body = {"mode": mode, "render": render}
        if peak_nits is not None:
            body["peak_nits"] = peak_nits
        status, _, data = self.request("POST", "/v1/selftest", json.dumps(body),
                                       {"Content-Type": "application/json"})
        self._raise_for(status, data)
        return json.loads(data)

    def encode(self, exr_bytes, options=None, accept="image/png"):
        """POST /v1/encode: an OpenEXR file's bytes plus the same settings as render (sent as
        multipart/form-data: parts "image" and "request"). With "dump": true in `options`,
        returns the sidecar."""
        options = options or {}
        boundary = "hdrd-" + uuid.uuid4().hex
        parts = [
            (b'Content-Disposition: form-data; name="image"; filename="input.exr"\r\n'
             b"Content-Type: image/x-exr\r\n\r\n", exr_bytes),
            (b'Content-Disposition: form-data; name="request"\r\n'
             b"Content-Type: application/json\r\n\r\n", json.dumps(options).encode()),
        ]
        body = b"".join(b"--" + boundary.encode() + b"\r\n" + head + data + b"\r\n" for head, data in parts)
        body += b"--" + boundary.encode() + b"--\r\n"
        return self._answer("/v1/encode", body, "multipart/form-data; boundary=" + boundary, options.get("dump"), accept)

    # -- sequences and jobs (POST /v1/sequences, /v1/jobs) ----------------------------------
    def submit_sequence(self, request, source=None):
        """POST /v1/sequences: a render or encode request plus the sequence settings (frames,
        fps, start_s, images, video.*, metadata.*, ...; docs/settings.md). `source` is
        "render" or "encode"; by default encode when the request has "images" (a frame
        pattern, directory or list file in the daemon's asset root), else render. Returns
        the 202 answer: {"id", "name", "state", "frames_total", "links"}."""
        body = dict(request)
        if source is not None:
            body["source"] = source
        status, _, data = self.request("POST", "/v1/sequences", json.dumps(body), {"Content-Type": "application/json"})
        self._raise_for(status, data)
        return json.loads(data)

    def job(self, job_id):
        """GET /v1/jobs/{id}: state (queued, running, done, failed, cancelled), frames_done,
        frames_total, fps, eta_s, error, files, timestamps."""
        return self._get_json("/v1/jobs/" + job_id)

    def jobs(self):
        """GET /v1/jobs: {"jobs": [newest first], "queued", "running", "finished"}."""
        return self._get_json("/v1/jobs")

    def wait(self, job_id, progress=None, poll_s=0.25, timeout=None):
        """Polls until the job is final; calls progress(job) after every poll. Returns the
        final job when done; raises JobFailed when it failed or was cancelled, TimeoutError
        after `timeout` seconds (the job goes on)."""
        end = None if timeout is None else time.monotonic() + timeout
        while True:
            j = self.job(job_id)
            if progress is not None:
                progress(j)
            if j["state"] in FINAL_STATES:
                if j["state"] != "done":
                    raise JobFailed(j)
                return j
            if end is not None and time.monotonic() > end:
                raise TimeoutError(f"job {job_id} is still {j['state']} after {timeout} s")
            time.sleep(poll_s)

    def result(self, job_id, path, keep=False):
        """GET /v1/jobs/{id}/result into `path` (streamed, never held in memory): the video,
        or the sequence sidecar when the request had no video. Returns the media type.
        Once downloaded, the job's files in the daemon's dump directory are a copy nobody
        asked to keep: they are removed (DELETE /v1/jobs/{id}, as `hdrctl -o` does) unless
        keep=True. HdrdError 409 job.not_ready while the job runs."""
        conn = self._connection()
        headers = {"Authorization": "Bearer " + self.token} if self.token else {}
        try:
            conn.request("GET", f"/v1/jobs/{job_id}/result", headers=headers)
            resp = conn.getresponse()
            if resp.status >= 400:
                self._raise_for(resp.status, resp.read())
            tmp = f"{path}.tmp-{os.getpid()}"
            try:
                with open(tmp, "wb") as f:
                    shutil.copyfileobj(resp, f, 1 << 20)
                os.replace(tmp, path)
            finally:
                if os.path.exists(tmp):
                    os.remove(tmp)
            media_type = resp.getheader("Content-Type", "")
        except (http.client.HTTPException, OSError):
            self.close()
            raise
        if not keep:
            self.cancel(job_id)
        return media_type

    def sidecar(self, job_id):
        """GET /v1/jobs/{id}/sidecar: the sequence sidecar (docs/sequences.md) as a dict."""
        return self._get_json(f"/v1/jobs/{job_id}/sidecar")

    def cancel(self, job_id):
        """DELETE /v1/jobs/{id}: cancels a queued or running job (its partial files are
        removed) or removes a finished job's files. Returns the job's final state."""
        status, _, data = self.request("DELETE", "/v1/jobs/" + job_id)
        self._raise_for(status, data)
        return json.loads(data)
