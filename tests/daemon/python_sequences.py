"""The Python client's sequence calls against a running daemon (run by
tests/daemon/sequences_test.cpp: python3 python_sequences.py SOCKET DUMP_DIR CLIENT_DIR).
The asset root holds shot/shot.0000.exr .. shot.0005.exr. Exits non-zero on a failure."""

import os
import sys
import tempfile

sys.path.insert(0, sys.argv[3])
from hdrd_client import HdrdClient, HdrdError, JobFailed  # noqa: E402

socket_path, dump_dir = sys.argv[1], sys.argv[2]
c = HdrdClient(socket_path=socket_path, timeout=60)

accepted = c.submit_sequence({"images": "shot/shot.%04d.exr", "name": "py", "display": {"mode": "hdr10"},
                              "video": {"codec": "hevc", "preset": "ultrafast"}})
assert accepted["state"] in ("queued", "running"), accepted
assert accepted["frames_total"] == 6, accepted

seen = []
job = c.wait(accepted["id"], progress=lambda j: seen.append(j["frames_done"]), poll_s=0.02)
assert job["state"] == "done" and job["frames_done"] == 6, job
assert seen == sorted(seen) and seen[-1] == 6, seen  # progress only goes forward
assert c.job(accepted["id"])["state"] == "done"
assert any(j["id"] == accepted["id"] for j in c.jobs()["jobs"])

with tempfile.TemporaryDirectory() as tmp:
    out = os.path.join(tmp, "py.mp4")
    assert c.result(accepted["id"], out, keep=True) == "video/mp4"
    with open(out, "rb") as a, open(os.path.join(dump_dir, "py.mp4"), "rb") as b:
        assert a.read() == b.read(), "the downloaded video differs from the daemon's file"
assert c.sidecar(accepted["id"])["frame_count"] == 6

# Without keep, a download removes the job's files from the dump directory (as hdrctl -o).
tidy = c.submit_sequence({"images": "shot/shot.%04d.exr", "name": "pytidy", "display": {"mode": "hdr10"},
                          "video": {"codec": "hevc", "preset": "ultrafast"}})
c.wait(tidy["id"], poll_s=0.02)
assert [f for f in os.listdir(dump_dir) if f.startswith("pytidy.")], os.listdir(dump_dir)
with tempfile.TemporaryDirectory() as tmp:
    out = os.path.join(tmp, "pytidy.mp4")
    assert c.result(tidy["id"], out) == "video/mp4"
    assert os.path.getsize(out) > 0
assert not [f for f in os.listdir(dump_dir) if f.startswith("pytidy.")], os.listdir(dump_dir)
assert c.job(tidy["id"])["files_removed"] is True

try:
    c.job("0000000000000000")
    raise AssertionError("an unknown job was found")
except HdrdError as e:
    assert e.status == 404 and e.code == "job.not_found", e

# A sequence whose second frame is not an EXR: accepted (the first frame is), then failed.
failing = c.submit_sequence({"images": "bad/b.%04d.exr", "name": "pybad"})
try:
    c.wait(failing["id"], poll_s=0.02)
    raise AssertionError("a job with a corrupt frame finished")
except JobFailed as e:
    assert e.job["state"] == "failed" and e.job["error"]["code"].startswith("exr."), e.job
assert not [f for f in os.listdir(dump_dir) if f.startswith("pybad")], os.listdir(dump_dir)

removed = c.cancel(accepted["id"])
assert removed["files_removed"] is True, removed
assert not [f for f in os.listdir(dump_dir) if f.startswith("py.")], os.listdir(dump_dir)
print("python sequences: ok")
