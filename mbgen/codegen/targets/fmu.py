r"""FMI 2.0 export: a scene as a Functional Mock-up Unit (model exchange and co-simulation).

``export_fmu(scene, "out/")`` (``mbgen fmu SCENE -o DIR``) writes
``<prefix>.fmu``, a zip with::

    modelDescription.xml            variables, capabilities, model structure
    sources/<prefix>.h, .c          the model (with the step API target)
    sources/<prefix>_fmi2.h         FMI 2.0 types (written from the standard)
    sources/<prefix>_fmu.c          the FMI functions (templates/fmu/fmu.c.j2)
    binaries/<platform>/<prefix>.so|.dylib|.dll   built here with the C compiler

Variables (all ``Real``; value references in this order)::

    x        states: causality output, continuous, initial exact, start = the
             scene's initial state
    der(x)   derivatives: local, derivative = index of the state
    p        free parameters: causality parameter, variability tunable, start =
             the scene's value.  Baked (fixed) parameters are not variables.
    r        inputs: causality input, continuous, start 0
    outputs  energy ``T``, ``V``; point positions and velocities, the mass matrix
             and forcing when the scene requests them: output, continuous, calculated

Co-simulation steps with the scene's adaptive method (``rosenbrock`` when it
asks for it, else ``dopri5``) through the step API: ``rtol`` is the
experiment's tolerance (``fmi2SetupExperiment``; default the scene's
``DefaultExperiment``, 1e-6), ``atol = 1e-3 rtol``; inputs are held constant
over a communication step.  Model exchange exposes the RHS to the importer's
integrator (no events, except for configuration constraints, below).

Configuration constraints: co-simulation projects after every step (the step
API).  Model exchange cannot, as the importer's integrator owns the state: so
``fmi2CompletedIntegratorStep`` asks for a step event once the residual
``max|f_h|`` passes :data:`PROJECT_TOL` ``(1 + max|q_r|)``, and
``fmi2NewDiscreteStates`` projects the dependent coordinates back
(``valuesOfContinuousStatesChanged``).  Both modes project the initial state in
``fmi2ExitInitializationMode``.  User text reaches the XML only through
:func:`mbgen.codegen.escape.xml_attr`.

Why no third-party FMI package: FMPy ships the standard headers but is an
importer (a test dependency here, not a run-time one); pythonfmu and PyFMI
wrap Python or import FMUs.  The glue is one template of plain C (~500 lines)
and the types are a page of the standard, so the FMU needs nothing but a C
compiler.
"""

from __future__ import annotations

import hashlib
import os
import platform
import struct
import subprocess
import tempfile
import zipfile
from pathlib import Path

from ..._version import __version__
from ...errors import BuildError, ModelError
from ..escape import xml_attr
from ...abi import Output
from ...abi import CONSTRAINT_STATUS_CODES, INTEGRATOR_STATUS_CODES, STATUS_CODES
from ..templating import environment
from . import Targets
from .step import adaptive_method

#: Model exchange: residual (relative to 1 + max|q_r|) above which a step event projects.
PROJECT_TOL = 1e-9
#: Outputs that become FMU output variables (the others are derivatives or integrators).
FMU_OUTPUTS = (Output.ENERGY, Output.POSITIONS, Output.VELOCITIES, Output.MASS_MATRIX,
               Output.FORCING)
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


def _library_suffix() -> str:
    return {"Darwin": ".dylib", "Windows": ".dll"}.get(platform.system(), ".so")


def _guid(text: str) -> str:
    h = hashlib.sha256(text.encode()).hexdigest()
    return "{" + f"{h[:8]}-{h[8:12]}-{h[12:16]}-{h[16:20]}-{h[20:32]}" + "}"


def _c(v) -> str:
    return repr(float(v))


def fmu_files(scene, result) -> dict[str, str]:
    """``{path inside the FMU: text}`` (all but the binary) for a pipeline result."""
    rendered, L = result.rendered, result.layout
    prefix = rendered.prefix
    kernel = result.kernel
    if not rendered.step_methods:
        raise ModelError("an FMU needs the step API: render with Targets(step=True)")
    method = adaptive_method(kernel)
    infos = {Output(f.output): f for f in rendered.functions}
    x0 = scene.x0(L)
    p0 = scene.p(L)
    n_x, n_p, n_r = L.n_x, L.n_p, L.n_r
    vr = dict(x=0, dx=n_x, p=2 * n_x, r=2 * n_x + n_p, out=2 * n_x + n_p + n_r)
    variables = [dict(name=n, vr=i, description=("generalized coordinate" if i < L.n_q
                                                 else "generalized speed"),
                      causality="output", variability="continuous", initial="exact",
                      start=_c(x0[i]), derivative=None) for i, n in enumerate(L.state_names)]
    variables += [dict(name=f"der({n})", vr=n_x + i, description=f"time derivative of {n}",
                       causality="local", variability="continuous", initial="calculated",
                       start=None, derivative=i + 1) for i, n in enumerate(L.state_names)]
    variables += [dict(name=n, vr=vr["p"] + i, description="free parameter (tunable)",
                       causality="parameter", variability="tunable", initial="exact",
                       start=_c(p0[i]), derivative=None)
                  for i, n in enumerate(L.parameter_names)]
    variables += [dict(name=n, vr=vr["r"] + i, description="input (force or torque), "
                       "held constant over a co-simulation step", causality="input",
                       variability="continuous", initial=None, start="0.0", derivative=None)
                  for i, n in enumerate(L.input_names)]
    outputs, start = [], vr["out"]
    for o in FMU_OUTPUTS:
        info = infos.get(o)
        if info is None:
            continue
        labels = ("T", "V") if o is Output.ENERGY else info.out_labels
        outputs.append(dict(c_name=info.c_name, field=o.value, size=info.out_size, start=start,
                            end=start + info.out_size,
                            args="".join(f", c->{a}" for a in info.args[2:])))
        variables += [dict(name=f"{o.value}.{label}", vr=start + j,
                           description=f"{o.value} output {j}", causality="output",
                           variability="continuous", initial="calculated", start=None,
                           derivative=None) for j, label in enumerate(labels)]
        start += info.out_size
    vr["end"] = start
    names = [v["name"] for v in variables]
    if len(set(names)) != len(names):
        dup = sorted({n for n in names if names.count(n) > 1})
        raise ModelError(f"FMU variable names {dup} occur twice; rename the symbols or points")
    for v in variables:
        v["name"] = xml_attr(v["name"])
        v["description"] = xml_attr(v["description"])
    index = {v["vr"]: i + 1 for i, v in enumerate(variables)}
    structure = dict(
        outputs=[index[i] for i in range(n_x)] + [index[i] for i in range(vr["out"], start)],
        derivatives=[index[n_x + i] for i in range(n_x)],
        initial=sorted([index[n_x + i] for i in range(n_x)]
                       + [index[i] for i in range(vr["out"], start)]))
    sources = [f"{prefix}.c", f"{prefix}_fmu.c"]
    env = environment()
    t0, t1 = (float(v) for v in scene.t_span)
    ctx = dict(version=__version__, prefix=prefix, upper=prefix.upper(), guid="GUID",
               model_name=xml_attr(scene.name), description=xml_attr(scene.description),
               sources=sources, start_time=_c(t0), stop_time=_c(t1), tolerance="1e-06",
               variables=variables, structure=structure)
    description = env.get_template("fmu/modelDescription.xml.j2").render(ctx)
    guid = _guid(rendered.digest() + description)
    description = description.replace('guid="GUID"', f'guid="{guid}"')
    codes = [(n, v, t.replace('"', "'")) for n, v, t in STATUS_CODES + INTEGRATOR_STATUS_CODES
             + CONSTRAINT_STATUS_CODES]
    c = kernel.equations.constraints
    project = None
    if c is not None and c.m_h:
        project = dict(m=c.m_h, dep=[L.state_names.index(str(q)) for q in
                                     c.dependent_coordinates],
                       holonomic=infos[Output.HOLONOMIC].c_name,
                       args="".join(f", m->{a}" for a in infos[Output.HOLONOMIC].args[2:]))
    glue = env.get_template("fmu/fmu.c.j2").render(dict(
        version=__version__, prefix=prefix, upper=prefix.upper(), guid=guid, method=method,
        n_x=n_x, n_p=n_p, n_r=n_r, vr=vr, outputs=outputs, x0=[_c(v) for v in x0],
        p0=[_c(v) for v in p0], rtol="1e-06", codes=codes, project_tol=_c(PROJECT_TOL),
        rhs_args="".join(f", c->{a}" for a in infos[Output.RHS].args[2:]),
        step_args="".join(f", m->{a}" for a, n in (("p", n_p), ("r", n_r)) if n),
        project=project))
    files = {"modelDescription.xml": description,
             f"sources/{prefix}_fmi2.h": env.get_template("fmu/fmi2.h.j2").render(
                 version=__version__, prefix=prefix, upper=prefix.upper()),
             f"sources/{prefix}_fmu.c": glue}
    files.update({f"sources/{name}": text for name, text in rendered.files.items()
                  if not name.endswith(".py")})
    return files


def build_binary(files: dict[str, str], prefix: str) -> bytes:
    """Compile the FMU's sources into a shared library for this platform; its bytes."""
    from ...build.extension import compiler

    cc = compiler()
    with tempfile.TemporaryDirectory(prefix=f"mbgen-fmu-{prefix}-") as tmp:
        folder = Path(tmp)
        for name, text in files.items():
            if name.startswith("sources/"):
                (folder / name[len("sources/"):]).write_text(text, encoding="utf-8")
        lib = folder / (prefix + _library_suffix())
        cmd = [cc, *FMU_CFLAGS, "-o", str(lib), f"{prefix}_fmu.c", f"{prefix}.c", "-lm"]
        done = subprocess.run(cmd, cwd=folder, capture_output=True, text=True)
        if done.returncode != 0:
            raise BuildError(f"compiling the FMU of {prefix!r} failed ({' '.join(cmd)}):\n"
                             f"{done.stdout}{done.stderr}")
        return lib.read_bytes()


def export_fmu(scene, output_dir, *, name: str | None = None) -> Path:
    """Write ``<output_dir>/<prefix>.fmu`` for ``scene`` (a Scene); returns its path.

    The FMU holds the scene's outputs (its fixed parameters baked in) plus the
    step API; see the module docstring for what the model description lists.
    """
    from ...pipeline import run

    result = run(scene, build=False, name=name, targets=Targets(step=True))
    files = fmu_files(scene, result)
    prefix = result.rendered.prefix
    binary = build_binary(files, prefix)
    out = Path(output_dir)
    out.mkdir(parents=True, exist_ok=True)
    path = out / f"{prefix}.fmu"
    entries = sorted(files.items()) + [
        (f"binaries/{platform_folder()}/{prefix}{_library_suffix()}", binary)]
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", dir=out)
    os.close(fd)
    try:
        with zipfile.ZipFile(tmp, "w", zipfile.ZIP_DEFLATED) as zf:
            for arcname, data in entries:
                info = zipfile.ZipInfo(arcname, date_time=(1980, 1, 1, 0, 0, 0))
                info.compress_type = zipfile.ZIP_DEFLATED
                info.external_attr = 0o644 << 16
                zf.writestr(info, data)
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise
    return path


__all__ = ["export_fmu", "fmu_files", "build_binary", "platform_folder", "FMU_OUTPUTS"]
