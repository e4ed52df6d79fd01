"""PEP 517 / PEP 660 build backend for the one-module hdrd client, standard library only.

pip builds in an isolated environment holding only [build-system] requires; with this
backend that list is empty, so `pip install clients/python` works without an index. It
writes a py3-none-any wheel (hdrd_client.py and its .dist-info), an sdist, and an editable
wheel (a .pth file pointing here). Name, description and requires-python come from
pyproject.toml's [project]; the version is hdrd_client.__version__.
"""

import base64
import hashlib
import io
import os
import re
import tarfile
import zipfile

try:
    import tomllib
except ImportError:  # Python < 3.11: the three keys this backend reads, from simple lines
    tomllib = None

HERE = os.path.dirname(os.path.abspath(__file__))
MODULE = "hdrd_client"


def _project():
    with open(os.path.join(HERE, "pyproject.toml"), "rb") as f:
        text = f.read()
    if tomllib:
        return tomllib.loads(text.decode())["project"]
    return dict(re.findall(r'^(name|description|requires-python) = "(.*)"$', text.decode(), re.M))


def _version():
    with open(os.path.join(HERE, MODULE + ".py"), encoding="utf-8") as f:
        m = re.search(r'^__version__ = "([^"]+)"$', f.read(), re.M)
    if not m:
        raise RuntimeError(MODULE + ".py has no __version__ line")
    return m.group(1)


def _dist_name():
    return re.sub(r"[-_.]+", "_", _project()["name"])


def _metadata():
    p = _project()
    return (f"Metadata-Version: 2.1\nName: {p['name']}\nVersion: {_version()}\n"
            f"Summary: {p.get('description', '')}\nRequires-Python: {p.get('requires-python', '>=3')}\n")


def _dist_info():
    return f"{_dist_name()}-{_version()}.dist-info"


def _write_wheel(directory, files):
    """files: [(archive name, bytes)]; adds WHEEL, METADATA and RECORD."""
    info = _dist_info()
    files = list(files) + [
        (f"{info}/METADATA", _metadata().encode()),
        (f"{info}/WHEEL", b"Wheel-Version: 1.0\nGenerator: hdrd build_backend\nRoot-Is-Purelib: true\n"
                          b"Tag: py3-none-any\n"),
    ]
    record = io.StringIO()
    for name, data in files:
        digest = base64.urlsafe_b64encode(hashlib.sha256(data).digest()).rstrip(b"=").decode()
        record.write(f"{name},sha256={digest},{len(data)}\n")
    record.write(f"{info}/RECORD,,\n")
    files.append((f"{info}/RECORD", record.getvalue().encode()))
    wheel = f"{_dist_name()}-{_version()}-py3-none-any.whl"
    with zipfile.ZipFile(os.path.join(directory, wheel), "w", zipfile.ZIP_DEFLATED) as z:
        for name, data in files:
            z.writestr(zipfile.ZipInfo(name, date_time=(1980, 1, 1, 0, 0, 0)), data)
    return wheel


def _module_bytes():
    with open(os.path.join(HERE, MODULE + ".py"), "rb") as f:
        return f.read()


def get_requires_for_build_wheel(config_settings=None):
    return []


def get_requires_for_build_sdist(config_settings=None):
    return []


def get_requires_for_build_editable(config_settings=None):
    return []


def build_wheel(wheel_directory, config_settings=None, metadata_directory=None):
    return _write_wheel(wheel_directory, [(MODULE + ".py", _module_bytes())])


def build_editable(wheel_directory, config_settings=None, metadata_directory=None):
    return _write_wheel(wheel_directory, [(f"_{MODULE}_editable.pth", (HERE + "\n").encode())])


def build_sdist(sdist_directory, config_settings=None):
    base = f"{_dist_name()}-{_version()}"
    name = base + ".tar.gz"
    with tarfile.open(os.path.join(sdist_directory, name), "w:gz", format=tarfile.PAX_FORMAT) as t:
        for f in ("pyproject.toml", "build_backend.py", MODULE + ".py", "example.py"):
            t.add(os.path.join(HERE, f), arcname=f"{base}/{f}")
        pkg_info = _metadata().encode()
        ti = tarfile.TarInfo(f"{base}/PKG-INFO")
        ti.size = len(pkg_info)
        t.addfile(ti, io.BytesIO(pkg_info))
    return name
