r"""FMI 2.0 export, the render half: an FMU's model description and C glue from ``templates/fmu/``.

:func:`fmu_files` returns ``{path inside the FMU: text}`` for a scene and its kernel
rendered with the step API target; :data:`FMU`'s :meth:`~Fmu.archive` (``mbgen generate
--target fmu``, ``mbgen fmu``, :func:`mbgen.export.export_fmu`) has
:mod:`mbgen.build.fmu` compile the sources and write the zip::

    modelDescription.xml            variables, capabilities, model structure
    sources/<prefix>.h, .c          the model (with the step API target)
    sources/<prefix>_fmi2.h         FMI 2.0 types (written from the standard)
    sources/<prefix>_fmu.c          the FMI functions (templates/fmu/fmu.c.j2)

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
asks for it, else ``dopri5``: :func:`~mbgen.codegen.targets.step.adaptive_method`) through
the step API: ``rtol`` is the
experiment's tolerance (``fmi2SetupExperiment``; default the ``DefaultExperiment``'s,
:data:`mbgen.integrators.DEFAULT_RTOL`), ``atol = DEFAULT_ATOL * rtol / DEFAULT_RTOL``
(1e-6 and 1e-9 at the default); inputs are held constant over a communication step.
The inputs come from the importer (causality input, start 0): a table of inputs is
the importer's to feed (FMPy: ``simulate_fmu(..., input=...)``), and ``mbgen fmu``
refuses ``-r`` with that fix.  Model exchange exposes the RHS to the importer's
integrator (no events, except for configuration constraints, below).

The FMI 2.0 state machine (the standard's section 2.1 and its model-exchange and
co-simulation state charts, 3.2.3 and 4.2.4): the instance's state is one of
:data:`FMI2_STATES`, and each FMI function names the states it may be called in
(:data:`FMI2_ALLOWED`, the standard's tables as the Modelica Reference-FMUs enforce them,
rendered into the C as one mask per function).  A call in any other state -- exiting
initialisation without entering it, ``fmi2SetupExperiment`` or entering initialisation in
step mode, ``fmi2DoStep`` before initialisation, anything but the getters, ``fmi2Reset``
and ``fmi2FreeInstance`` after ``fmi2Terminate`` -- returns ``fmi2Error`` and logs
"illegal call sequence".  As the standard says of ``fmi2Error``, every call that returns
it leaves the instance in the error state, from which only the getters, ``fmi2Reset``
(back to instantiated, start values restored) and ``fmi2FreeInstance`` are allowed.

Time: ``fmi2DoStep`` refuses (``fmi2Error`` and a logged message naming the values) a
``currentCommunicationPoint`` that is NaN or not the FMU's time within
:data:`COMMUNICATION_POINT_TOL` (relative to ``max(1, |t|)``, the tolerance the
Reference-FMUs allow for the master's rounding: a step backwards or a jump ahead is
refused), and a ``communicationStepSize`` that is not a positive finite number.
``fmi2SetupExperiment`` and ``fmi2SetTime`` refuse a time that is not finite.

Input bounds (``Scene(saturate=True)``, off by default): ``fmi2SetReal`` stores an input
clamped to its bounds (the step API's ``<prefix>_input_lower`` / ``_upper``, see
:mod:`~mbgen.codegen.targets.step`), so both modes and every output read the clamped value,
``fmi2GetReal`` reads it back, and with debug logging on each clamp is logged (category
``logAll``: the input, the value given and the bound).  The input's description in the
model description states its bounds.  The XML's ``min`` / ``max`` attributes are not set:
the standard makes a value outside them illegal to set, while a saturating FMU takes any
value.

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
wrap Python or import FMUs.  The glue is one template of plain C (~800 lines)
and the types are a page of the standard, so the FMU needs nothing but a C
compiler.
"""

from __future__ import annotations

import hashlib
from pathlib import Path

from ..._version import __version__
from ...abi import CONSTRAINT_STATUS_CODES, INTEGRATOR_STATUS_CODES, STATUS_CODES, Output
from ...build.fmu import build_binary, write_fmu
from ...errors import ModelError
from ...integrators import DEFAULT_ATOL, DEFAULT_RTOL
from ..escape import xml_attr
from ..templating import environment
from .base import Job, Target
from .step import adaptive_method, saturation

#: Model exchange: residual (relative to 1 + max|q_r|) above which a step event projects.
PROJECT_TOL = 1e-9
#: fmi2DoStep: largest |currentCommunicationPoint - t| / max(1, |t|) taken for the FMU's time t.
COMMUNICATION_POINT_TOL = 1e-5

#: The FMI 2.0 states an instance can be in: the standard's, less those it never enters
#: (stepInProgress, stepFailed, stepCanceled: steps are synchronous and a failed step is an
#: error; fatal: never returned).
FMI2_STATES = ("instantiated", "initialization_mode", "event_mode", "continuous_time_mode",
               "step_complete", "terminated", "error")
_SET_UP = ("instantiated", "initialization_mode")
_RUNNING = ("event_mode", "continuous_time_mode", "step_complete")
_ENDED = ("terminated", "error")
_GETTERS = ("initialization_mode",) + _RUNNING + _ENDED
_ME_GETTERS = ("initialization_mode", "event_mode", "continuous_time_mode") + _ENDED

#: ``{FMI 2.0 function: the states it may be called in}`` (fmi2Instantiate, fmi2FreeInstance,
#: fmi2GetVersion and fmi2GetTypesPlatform are always allowed).  A call in another state is
#: refused with fmi2Error.
FMI2_ALLOWED = {
    "fmi2SetDebugLogging": FMI2_STATES,
    "fmi2SetupExperiment": ("instantiated",),
    "fmi2EnterInitializationMode": ("instantiated",),
    "fmi2ExitInitializationMode": ("initialization_mode",),
    "fmi2Terminate": _RUNNING,
    "fmi2Reset": FMI2_STATES,
    **dict.fromkeys(("fmi2GetReal", "fmi2GetInteger", "fmi2GetBoolean", "fmi2GetString",
                     "fmi2GetDirectionalDerivative"), _GETTERS),
    "fmi2SetReal": _SET_UP + _RUNNING,
    **dict.fromkeys(("fmi2SetInteger", "fmi2SetBoolean", "fmi2SetString"),
                    _SET_UP + ("event_mode", "step_complete")),
    **dict.fromkeys(("fmi2GetFMUstate", "fmi2SetFMUstate", "fmi2FreeFMUstate",
                     "fmi2SerializedFMUstateSize", "fmi2SerializeFMUstate",
                     "fmi2DeSerializeFMUstate"), FMI2_STATES),
    # model exchange
    "fmi2EnterEventMode": ("event_mode", "continuous_time_mode"),
    "fmi2NewDiscreteStates": ("event_mode",),
    "fmi2EnterContinuousTimeMode": ("event_mode",),
    "fmi2CompletedIntegratorStep": ("continuous_time_mode",),
    "fmi2SetTime": ("event_mode", "continuous_time_mode"),
    "fmi2SetContinuousStates": ("continuous_time_mode",),
    "fmi2GetEventIndicators": _ME_GETTERS,
    "fmi2GetContinuousStates": _ME_GETTERS,
    "fmi2GetDerivatives": ("event_mode", "continuous_time_mode") + _ENDED,
    "fmi2GetNominalsOfContinuousStates": ("instantiated", "event_mode",
                                          "continuous_time_mode") + _ENDED,
    # co-simulation
    "fmi2SetRealInputDerivatives": _SET_UP + ("step_complete",),
    "fmi2GetRealOutputDerivatives": ("step_complete",) + _ENDED,
    "fmi2DoStep": ("step_complete",),
    "fmi2CancelStep": (),                     # only while a step is in progress: never
    **dict.fromkeys(("fmi2GetStatus", "fmi2GetRealStatus", "fmi2GetIntegerStatus",
                     "fmi2GetBooleanStatus", "fmi2GetStringStatus"),
                    ("step_complete", "terminated")),
}

#: Outputs that become FMU output variables (the others are derivatives or integrators).
FMU_OUTPUTS = (Output.ENERGY, Output.POSITIONS, Output.VELOCITIES, Output.MASS_MATRIX,
               Output.FORCING)


class Fmu(Target):
    """The FMU: its texts rendered after the pipeline from the scene (:func:`fmu_files`), compiled
    and zipped into ``<prefix>.fmu``, an archive written whole into the output folder."""

    name = "fmu"
    files = (("modelDescription.xml.j2", "modelDescription.xml"),
             ("fmi2.h.j2", "sources/{prefix}_fmi2.h"), ("fmu.c.j2", "sources/{prefix}_fmu.c"))
    uses = ("step",)
    note = "FMI 2.0, model exchange and co-simulation"

    def wanted(self, kernel, targets) -> bool:
        return False

    def archive(self, job: Job, folder: Path) -> Path:
        """Compile the sources and write ``<folder>/<prefix>.fmu`` (:mod:`mbgen.build.fmu`)."""
        files = fmu_files(job.scene, job.kernel, job.rendered)
        prefix = job.rendered.prefix
        return write_fmu(folder, prefix, files, build_binary(files, prefix))


#: The FMU target.
FMU = Fmu()


def _guid(text: str) -> str:
    h = hashlib.sha256(text.encode()).hexdigest()
    return "{" + f"{h[:8]}-{h[8:12]}-{h[12:16]}-{h[16:20]}-{h[20:32]}" + "}"


def _c(v) -> str:
    return repr(float(v))


def _bounds(saturate: list | None, i: int) -> str:
    """``, saturated to [lower, upper]`` of input ``i`` (nothing without saturation)."""
    if not saturate:
        return ""
    b = saturate[i]
    ends = [v.replace("HUGE_VAL", "inf") for v in (b["lower"], b["upper"])]
    return f", saturated to [{ends[0]}, {ends[1]}]"


def fmu_files(scene, kernel, rendered) -> dict[str, str]:
    """``{path inside the FMU: text}`` (all but the binary) of ``scene``.

    ``kernel`` and ``rendered`` are the scene's, rendered with ``Targets(step=True)``.
    """
    L = kernel.layout
    prefix = rendered.prefix
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
    saturate = saturation(kernel)
    variables += [dict(name=n, vr=vr["r"] + i, description="input (force or torque), "
                       "held constant over a co-simulation step" + _bounds(saturate, i),
                       causality="input", variability="continuous", initial=None, start="0.0",
                       derivative=None)
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
    (xml_t, xml), (types_t, types), (glue_t, glue_c) = FMU.templates(prefix)
    t0, t1 = (float(v) for v in scene.t_span)
    ctx = dict(version=__version__, prefix=prefix, upper=prefix.upper(), guid="GUID",
               model_name=xml_attr(scene.name), description=xml_attr(scene.description),
               sources=sources, start_time=_c(t0), stop_time=_c(t1), tolerance=_c(DEFAULT_RTOL),
               variables=variables, structure=structure)
    description = env.get_template(xml_t).render(ctx)
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
    glue = env.get_template(glue_t).render(dict(
        version=__version__, prefix=prefix, upper=prefix.upper(), guid=guid, method=method,
        n_x=n_x, n_p=n_p, n_r=n_r, vr=vr, outputs=outputs, x0=[_c(v) for v in x0],
        p0=[_c(v) for v in p0], rtol=_c(DEFAULT_RTOL), atol=_c(DEFAULT_ATOL), codes=codes,
        project_tol=_c(PROJECT_TOL),
        rhs_args="".join(f", c->{a}" for a in infos[Output.RHS].args[2:]),
        step_args="".join(f", m->{a}" for a, n in (("p", n_p), ("r", n_r)) if n),
        project=project, states=FMI2_STATES, allowed=FMI2_ALLOWED, saturate=saturate,
        point_tol=_c(COMMUNICATION_POINT_TOL)))
    files = {xml: description,
             types: env.get_template(types_t).render(
                 version=__version__, prefix=prefix, upper=prefix.upper()),
             glue_c: glue}
    files.update({f"sources/{name}": text for name, text in rendered.files.items()
                  if not name.endswith(".py")})
    return files


__all__ = ["FMU", "Fmu", "fmu_files", "FMU_OUTPUTS", "PROJECT_TOL", "COMMUNICATION_POINT_TOL",
           "FMI2_STATES", "FMI2_ALLOWED"]
