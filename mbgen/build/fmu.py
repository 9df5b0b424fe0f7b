"""Build an FMU: its sources compiled into this platform's shared library, and the zip.

The texts come from :func:`mbgen.codegen.targets.fmu.fmu_files` (``{path inside the
FMU: text}``); :func:`build_binary` compiles ``sources/<prefix>.c`` and
``sources/<prefix>_fmu.c`` with :data:`FMU_CFLAGS`, and :func:`write_fmu` writes the
zip: the texts and ``binaries/<platform>/<prefix>.so|.dylib|.dll``
(:func:`platform_folder`), every entry dated 1980-01-01 with mode 0644, written to a
temporary file in the output folder and renamed into place (no half-written FMU;
:func:`mbgen.fileio.atomic_path`).  The ``.fmu`` itself gets the mode of every other
output: 0666 minus the umask, or the mode of the FMU it replaces.
"""

from __future__ import annotations

import platform
import struct
import subprocess
import tempfile
import zipfile
from pathlib import Path

from ..errors import BuildError
from ..fileio import atomic_path
from .extension import compiler, library_suffix

#: Flags of the FMU's shared library.
FMU_CFLAGS = ("-std=c99", "-O2", "-ffp-contract=off", "-fPIC", "-shared")


def platform_folder() -> str:
    """FMI 2.0 platform name of this machine (``linux64``, ``darwin64``, ``win64``, ...)."""
    bits = 8 * struct.calcsize("P")
    system = platform.system()
    name = {"Linux": "linux", "Darwin": "darwin", "Windows": "win"}.get(system)
    if name is None:
        raise BuildError(f"FMI 2.0 defines no binary folder for {system}; use the sources/")
    return f"{name}{bits}"


def build_binary(files: dict[str, str], prefix: str) -> bytes:
    """Compile the FMU's sources into a shared library for this platform; its bytes."""
    cc = compiler()
    with tempfile.TemporaryDirectory(prefix=f"mbgen-fmu-{prefix}-") as tmp:
        folder = Path(tmp)
        for name, text in files.items():
            if name.startswith("sources/"):
                (folder / name[len("sources/"):]).write_text(text, encoding="utf-8")
        lib = folder / (prefix + library_suffix())
        cmd = [cc, *FMU_CFLAGS, "-o", str(lib), f"{prefix}_fmu.c", f"{prefix}.c", "-lm"]
        done = subprocess.run(cmd, cwd=folder, capture_output=True, text=True)
        if done.returncode != 0:
            raise BuildError(f"compiling the FMU of {prefix!r} failed ({' '.join(cmd)}):\n"
                             f"{done.stdout}{done.stderr}")
        return lib.read_bytes()


def write_fmu(output_dir, prefix: str, files: dict[str, str], binary: bytes) -> Path:
    """Write ``<output_dir>/<prefix>.fmu`` holding ``files`` and ``binary``; returns its path."""
    out = Path(output_dir)
    out.mkdir(parents=True, exist_ok=True)
    path = out / f"{prefix}.fmu"
    entries = sorted(files.items()) + [
        (f"binaries/{platform_folder()}/{prefix}{library_suffix()}", binary)]
    with atomic_path(path) as tmp, zipfile.ZipFile(tmp, "w", zipfile.ZIP_DEFLATED) as zf:
        for arcname, data in entries:
            info = zipfile.ZipInfo(arcname, date_time=(1980, 1, 1, 0, 0, 0))
            info.compress_type = zipfile.ZIP_DEFLATED
            info.external_attr = 0o644 << 16
            zf.writestr(info, data)
    return path


__all__ = ["FMU_CFLAGS", "platform_folder", "library_suffix", "build_binary", "write_fmu"]
