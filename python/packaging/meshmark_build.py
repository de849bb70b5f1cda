"""The build backend of `pip install .` (PEP 517, in the tree, needing nothing from the network):
configures meshmark with CMake and Ninja, builds the Python module and its type stubs, and
packs them into a wheel.

The build tree is build-pip/ in the checkout, or the folder named by the environment variable
MESHMARK_PIP_BUILD_DIR (an existing build tree is reused: only what changed is rebuilt).
"""

import base64
import hashlib
import os
import pathlib
import re
import subprocess
import sys
import sysconfig
import zipfile

ROOT = pathlib.Path(__file__).resolve().parents[2]


def _version():
    text = (ROOT / "CMakeLists.txt").read_text(encoding="utf-8")
    return re.search(r"project\(meshmark\s+VERSION\s+([0-9.]+)", text).group(1)


def _build():
    build = pathlib.Path(os.environ.get("MESHMARK_PIP_BUILD_DIR", ROOT / "build-pip"))
    if not (build / "CMakeCache.txt").exists():
        subprocess.run(["cmake", "-S", str(ROOT), "-B", str(build), "-G", "Ninja",
                        "-DCMAKE_BUILD_TYPE=Release", "-DMESHMARK_BUILD_TESTS=OFF",
                        "-DMESHMARK_BUILD_BENCH=OFF", f"-DPython3_EXECUTABLE={sys.executable}"],
                       check=True, stdout=sys.stderr)
    subprocess.run(["cmake", "--build", str(build), "--target", "meshmark_python"], check=True,
                   stdout=sys.stderr)
    module = sorted((build / "python").glob("meshmark*.so"))
    stubs = build / "python" / "meshmark.pyi"
    if not module or not stubs.exists():
        raise RuntimeError(f"meshmark: no module or stubs in {build / 'python'}")
    return module[0], stubs


def _record_line(name, data):
    digest = base64.urlsafe_b64encode(hashlib.sha256(data).digest()).rstrip(b"=").decode()
    return f"{name},sha256={digest},{len(data)}"


def get_requires_for_build_wheel(config_settings=None):
    return []


def build_wheel(wheel_directory, config_settings=None, metadata_directory=None):
    module, stubs = _build()
    version = _version()
    tag = f"cp{sys.version_info.major}{sys.version_info.minor}"
    platform = sysconfig.get_platform().replace("-", "_").replace(".", "_")
    name = f"meshmark-{version}-{tag}-{tag}-{platform}.whl"
    info = f"meshmark-{version}.dist-info"
    files = {
        module.name: module.read_bytes(),
        "meshmark.pyi": stubs.read_bytes(),
        # PEP 561 covers packages, not a lone extension module: type checkers that ignore the
        # stubs beside it read this stub-only package.
        "meshmark-stubs/__init__.pyi": stubs.read_bytes(),
        f"{info}/METADATA": (
            f"Metadata-Version: 2.1\nName: meshmark\nVersion: {version}\n"
            "Summary: Blind, robust watermarking of triangle meshes, and tracing of leaks\n"
            "License: GPL-3.0-or-later\nRequires-Python: >=3.9\nRequires-Dist: numpy\n").encode(),
        f"{info}/WHEEL": (f"Wheel-Version: 1.0\nGenerator: meshmark_build\nRoot-Is-Purelib: false\n"
                          f"Tag: {tag}-{tag}-{platform}\n").encode(),
        f"{info}/LICENSE": (ROOT / "LICENSE").read_bytes(),
    }
    record = [_record_line(n, d) for n, d in files.items()] + [f"{info}/RECORD,,"]
    files[f"{info}/RECORD"] = ("\n".join(record) + "\n").encode()
    path = pathlib.Path(wheel_directory) / name
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as wheel:
        for n, d in files.items():
            wheel.writestr(n, d)
    return name
