#!/usr/bin/env python3
"""Example: drive hdrd from Python with the standard library only.

    python3 clients/python/example.py [--socket PATH] [--out DIR]

Prints the daemon's status and tone curves, renders the default scene as HDR10 PNG and as
an SDR raw DRM buffer, fetches a test pattern, runs the HDR10 self-test, and shows how an
error comes back.
"""

import argparse
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from hdrd_client import HdrdClient, HdrdError, default_socket  # noqa: E402


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--socket", default=default_socket(), help="daemon socket")
    ap.add_argument("--out", default=".", help="directory for the frames")
    args = ap.parse_args()

    with HdrdClient(args.socket) as c:
        st = c.status()
        r = st.get("renderer", {})
        print(f"hdrd {st['version']}, renderer: {r.get('backend', 'none')} {r.get('gl_renderer', '')}")
        caps = c.capabilities()
        print("tone curves:", ", ".join(cv["name"] for cv in caps["tone_curves"]))

        frame = c.render({"width": 256, "height": 144, "display": {"mode": "hdr10", "peak_nits": 1000}})
        path = os.path.join(args.out, "example-hdr10.png")
        with open(path, "wb") as f:
            f.write(frame.data)
        print(f"{path}: {frame!r}, MaxCLL {frame.metadata['maxcll']} MaxFALL {frame.metadata['maxfall']}")

        raw = c.render({"width": 128, "height": 72, "display": {"mode": "sdr"}}, accept="application/octet-stream")
        m = raw.metadata
        assert len(raw.data) == int(m["stride"]) * int(m["height"])
        print(f"raw {m['fourcc']} buffer: {len(raw.data)} bytes, stride {m['stride']}")

        win = c.pattern("window", params={"level_nits": 1000, "area_percent": 10},
                        display={"mode": "hdr10", "peak_nits": 1000}, width=192, height=108)
        path = os.path.join(args.out, "example-window.png")
        with open(path, "wb") as f:
            f.write(win.data)
        print(f"{path}: {win!r}, pattern {win.metadata['pattern']}")

        report = c.selftest("hdr10", peak_nits=1000)
        failed = [ch["name"] for ch in report["checks"] if not ch["passed"] and not ch["skipped"]]
        print(f"selftest hdr10 1000: {len(report['checks'])} checks, passed={report['passed']}"
              + (f", failed: {', '.join(failed)}" if failed else ""))

        try:
            c.render({"width": "wide"})
        except HdrdError as e:
            print(f"as expected: HTTP {e.status} {e.code} on field '{e.field}': {e.message}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
