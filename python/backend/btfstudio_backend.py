"""A PEP 517 build backend that wheels the btfstudio package the CMake build made.

pip install ./python          a wheel of BUILD/python/btfstudio (the extension and the .py files)
pip install -e ./python       an editable install: a .pth naming BUILD/python

BUILD is $BTF_BUILD_DIR, else the build/ folder beside python/. The extension must be the one
built for the interpreter pip runs under (its EXT_SUFFIX); otherwise the build stops with what to
run. Nothing is compiled or downloaded here (docs/python.md "Installing").
"""
import base64
import hashlib
import os
import pathlib
import re
import sysconfig
import zipfile

_HERE = pathlib.Path(__file__).resolve().parent.parent  # python/


def _version():
    text = (_HERE / "pyproject.toml").read_text()
    m = re.search(r'^version\s*=\s*"([^"]+)"', text, re.M)
    if not m:
        raise RuntimeError(f"{_HERE / 'pyproject.toml'}: no version = \"...\" line")
    return m.group(1)


def _package_dir():
    build = pathlib.Path(os.environ.get("BTF_BUILD_DIR", _HERE.parent / "build")).resolve()
    pkg = build / "python" / "btfstudio"
    suffix = sysconfig.get_config_var("EXT_SUFFIX")
    ext = pkg / ("_core" + suffix)
    if not ext.is_file():
        found = sorted(p.name for p in pkg.glob("_core*")) if pkg.is_dir() else []
        raise RuntimeError(
            f"btfstudio: {ext} is missing"
            + (f" (found {', '.join(found)}: built for another Python)" if found else "")
            + ". Build the package first with the Python that pip runs under: `make` "
            "(or `cmake --build build --target btf_python`), or set BTF_BUILD_DIR to that build."
        )
    return build, pkg, ext


def _tag():
    impl = f"cp{sysconfig.get_config_var('py_version_nodot')}"
    plat = sysconfig.get_platform().replace("-", "_").replace(".", "_")
    return f"{impl}-{impl}-{plat}"


def _metadata(version):
    return (
        "Metadata-Version: 2.1\n"
        "Name: btfstudio\n"
        f"Version: {version}\n"
        "Summary: BTF Studio's readers, requests and Mitsuba 3 BSDF\n"
        "Requires-Python: >=3.9\n"
        "Requires-Dist: numpy\n"
    )


def _write_wheel(wheel_directory, files):
    """files: (name in the wheel, bytes). Adds WHEEL, METADATA and RECORD; returns the name."""
    version, tag = _version(), _tag()
    dist = f"btfstudio-{version}.dist-info"
    files = list(files) + [
        (f"{dist}/METADATA", _metadata(version).encode()),
        (f"{dist}/WHEEL", (
            "Wheel-Version: 1.0\nGenerator: btfstudio_backend\nRoot-Is-Purelib: false\n"
            f"Tag: {tag}\n").encode()),
    ]
    record = []
    for name, data in files:
        digest = base64.urlsafe_b64encode(hashlib.sha256(data).digest()).rstrip(b"=").decode()
        record.append(f"{name},sha256={digest},{len(data)}")
    record.append(f"{dist}/RECORD,,")
    files.append((f"{dist}/RECORD", ("\n".join(record) + "\n").encode()))
    name = f"btfstudio-{version}-{tag}.whl"
    out = pathlib.Path(wheel_directory) / name
    tmp = out.with_suffix(".whl.partial")
    with zipfile.ZipFile(tmp, "w", zipfile.ZIP_DEFLATED) as z:
        for n, data in files:
            info = zipfile.ZipInfo(n, date_time=(2026, 1, 1, 0, 0, 0))
            info.external_attr = (0o755 if n.endswith(".so") else 0o644) << 16
            info.compress_type = zipfile.ZIP_DEFLATED
            z.writestr(info, data)
    os.replace(tmp, out)
    return name


def get_requires_for_build_wheel(config_settings=None):
    return []


def get_requires_for_build_editable(config_settings=None):
    return []


def build_wheel(wheel_directory, config_settings=None, metadata_directory=None):
    _, pkg, ext = _package_dir()
    files = [(f"btfstudio/{p.name}", p.read_bytes()) for p in sorted(pkg.glob("*.py"))]
    files.append((f"btfstudio/{ext.name}", ext.read_bytes()))
    # The engine's OpenImageIO module, loaded from beside _core on the first image read or write.
    mod = pkg / "libbtf_oiio.so"
    if not mod.is_file():
        raise RuntimeError(f"btfstudio: {mod} is missing: rebuild the package (`make`)")
    files.append((f"btfstudio/{mod.name}", mod.read_bytes()))
    return _write_wheel(wheel_directory, files)


def build_editable(wheel_directory, config_settings=None, metadata_directory=None):
    build, _, _ = _package_dir()
    return _write_wheel(wheel_directory, [("btfstudio-build.pth", f"{build / 'python'}\n".encode())])
