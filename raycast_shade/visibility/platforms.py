"""Where the Embree 4 binding comes from, checked when the package is imported.

The kernels bind Embree 4 inside the ``embreex`` wheel (:mod:`.embree`). PyPI has
embreex 4 wheels for Linux x86_64 (glibc 2.28+), Windows x86_64 and macOS 13+ (arm64
and x86_64) only (:data:`EMBREE4_WHEELS`, read from the wheel files of embreex
4.4.0.post1). Elsewhere pip finds no wheel (Linux aarch64, musl Linux, macOS arm64
before 13) or, on Intel macOS before 13, embreex 2.17 (Embree 2, whose structs and calls
are not Embree 4's). :func:`require_embreex` turns each of these into one
``ImportError`` naming the platform and the remedy, raised by ``import raycast_shade``,
instead of a loader error at the first render.
"""

from __future__ import annotations

import importlib
import platform

__all__ = ["EMBREE4_WHEELS", "platform_name", "embreex_version", "require_embreex"]

# (system, machines, what pip needs): the platforms with an embreex 4 wheel on PyPI.
EMBREE4_WHEELS = (
    ("Linux", ("x86_64", "amd64"), "glibc 2.28+"),
    ("Windows", ("x86_64", "amd64"), ""),
    ("Darwin", ("arm64", "x86_64"), "macOS 13+"),
)
_WHEELS_TEXT = "Linux x86_64 (glibc 2.28+), Windows x86_64 and macOS 13+ (arm64 or x86_64)"
_REMEDY_SOURCE = ("or build embreex from source against an Embree 4 library "
                  "(https://github.com/trimesh/embreex, Embree 4 from https://github.com/RenderKit/embree)")


def platform_name(system: str | None = None, machine: str | None = None, mac: str | None = None) -> str:
    """``"Linux aarch64"``, ``"macOS 12.6 x86_64"``, ...: this machine, or the one given."""
    system = platform.system() if system is None else system
    machine = platform.machine() if machine is None else machine
    if system == "Darwin":
        mac = platform.mac_ver()[0] if mac is None else mac
        return f"macOS {mac or '(version unknown)'} {machine}"
    return f"{system} {machine}"


def _has_wheel(system: str, machine: str, mac: str) -> bool | None:
    """Whether PyPI has an embreex 4 wheel for the platform (None: cannot tell, e.g. no macOS version)."""
    for name, machines, _ in EMBREE4_WHEELS:
        if system == name and machine.lower() in machines:
            if system != "Darwin":
                return True
            try:
                return int(mac.split(".")[0]) >= 13
            except ValueError:
                return None
    return False


def embreex_version(module) -> str | None:
    """The installed embreex's version: its ``__version__`` (embreex 4 reads its distribution's
    metadata), else the distribution's metadata (embreex 2 has no attribute); None when neither says."""
    try:
        version = getattr(module, "__version__", None)
    except Exception:  # embreex 4's module __getattr__ reads metadata, which may be absent
        version = None
    if isinstance(version, str) and version:
        return version
    from importlib import metadata

    try:
        return metadata.version("embreex")
    except metadata.PackageNotFoundError:
        return None


def _message(problem: str, system: str, machine: str, mac: str) -> str:
    where = platform_name(system, machine, mac)
    wheel = _has_wheel(system, machine, mac)
    if wheel:
        remedy = f"pip install --upgrade 'embreex>=4.4' (PyPI has its wheel for {where})"
    elif wheel is None:
        remedy = f"pip install --upgrade 'embreex>=4.4' on macOS 13+, {_REMEDY_SOURCE}"
    elif system == "Darwin" and machine == "x86_64":
        remedy = (f"PyPI's embreex 4 wheels need macOS 13+ (before 13 pip picks embreex 2.17, Embree 2): "
                  f"update macOS and pip install --upgrade 'embreex>=4.4', {_REMEDY_SOURCE}")
    else:
        remedy = f"PyPI has no embreex 4 wheel for {where}: use one of those platforms, {_REMEDY_SOURCE}"
    return (f"raycast_shade needs embreex 4 (Embree 4; wheels for {_WHEELS_TEXT}); {problem} on {where}. "
            f"Remedy: {remedy}.")


def require_embreex(system: str | None = None, machine: str | None = None, mac: str | None = None) -> str | None:
    """Import ``embreex`` and check it binds Embree 4; return its version (None: it does not say).

    Only the Python package is imported (no library is loaded: that is the first render's,
    :mod:`.embree`). ``system``, ``machine`` and ``mac`` stand in for this machine's
    (tests).

    Raises
    ------
    ImportError
        Naming the platform and the remedy, when embreex cannot be imported or its
        version is below 4 (an Embree 2 or 3 binding).
    """
    system = platform.system() if system is None else system
    machine = platform.machine() if machine is None else machine
    mac = (platform.mac_ver()[0] if system == "Darwin" else "") if mac is None else mac
    try:
        module = importlib.import_module("embreex")
    except ImportError as exc:
        raise ImportError(_message(f"embreex cannot be imported ({exc})", system, machine, mac),
                          name="embreex") from exc
    version = embreex_version(module)
    major = version.split(".")[0] if version else ""
    if major.isdigit() and int(major) < 4:
        raise ImportError(_message(f"the installed embreex {version} binds Embree {major}, whose structs and "
                                   "calls the kernels cannot use", system, machine, mac), name="embreex")
    return version
