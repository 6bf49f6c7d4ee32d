"""Export the equations of motion as standalone files: C, Python, MATLAB/Octave, LaTeX.

For n coordinates and m actuators the code files hold, with no dependency on
anadyn (C: <math.h>; Python: math; MATLAB: none):

    mass_matrix(q)            M, n x n            forcing(t, q, dq)      F, n
    input_matrix(q)           B, n x m            efforts(t, q, dq)      the control laws
    accelerations(t, q, dq, tau)   ddq from M ddq = F + B tau   (open loop)
    rhs(t, x)                 [dq, ddq] under the control laws, x = [q, dq]
    jacobian(t, x)            d(rhs)/dx, analytic: [[0, I], [M^-1 K]]
    inverse(t, q, dq, ddq)    tau = pinv(B) (M ddq - F)

and the LaTeX document the equations in the "... = 0" form and M, F, B.
A robot with a spherical joint has nq coordinates (a unit quaternion each) and n
speeds u: the same functions of q and u (named ``u``, ``du``), plus
rates(q, u) = W(q) u (nq); rhs is [W(q) u, du] and jacobian [[R], [M^-1 K]],
nq + n.  The derivatives and the traced exports refuse it (x = [q, dq] there).
``casadi`` and ``jax`` export forward_dynamics(t, q, dq, tau), inverse_dynamics(t, q,
dq, ddq) and mass_matrix(q) from the recursive dynamics' traced statements
(``output.export.traced``): serialized ``casadi.Function``s, or a module of pure
``jax.numpy`` functions.
Parameters are folded in, or (``symbolic``) passed in as a struct / mapping
whose defaults are the robot file's values.  The inverse dynamics use B's
pseudo-inverse: B square and invertible gives the exact efforts; with fewer
actuators than coordinates the least-squares ones (exact only for a feasible
motion); with more, the smallest efforts that produce the motion.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path

from ..model.constraints import refuse_closed_chain
from ..errors import SettingError, ModelError
from .. import files as output
from .. import progress

LANGUAGES = ("python", "c", "matlab", "latex", "casadi", "jax")
#: languages built from the traced recursive dynamics (no formulation, no symbolic)
TRACED = ("casadi", "jax")
#: languages that can carry the derivatives' files (``derivatives``) and the regressor's
DERIVATIVES = ("c", "python")


@dataclass
class ExportResult:
    lang: str
    model: object                      # output.export.model.ExportModel
    files: dict[str, str]              # file name -> text
    fragment: bool = False
    timings: dict = field(default_factory=dict)


def check_options(lang: str, fragment: bool = False, symbolic: bool = False,
                  derivatives: bool = False, parameters=(), regressor: bool = False) -> None:
    """Refuse impossible combinations before any work (ModelError, exit 2), and
    ``casadi`` without CasADi installed."""
    if lang not in LANGUAGES:
        raise ModelError(f"unknown language {lang!r}; choose one of {', '.join(LANGUAGES)}")
    if fragment and lang != "latex":
        raise SettingError("fragment", f"applies to lang latex only, not {lang}")
    if derivatives and lang not in DERIVATIVES:
        raise SettingError("derivatives", f"applies to lang c and python, not {lang}")
    if derivatives and symbolic:
        raise SettingError("derivatives", "fold the robot file's numbers in, so not with "
                                          "symbolic (parameters names those to differentiate "
                                          "with respect to)")
    if regressor and lang not in DERIVATIVES:
        raise SettingError("regressor", f"applies to lang c and python, not {lang}")
    if regressor and symbolic:
        raise SettingError("regressor", "folds the robot file's numbers in, so not with "
                                        "symbolic")
    if parameters and not derivatives:
        raise SettingError("parameters", "needs derivatives (it names the parameters to "
                                         "differentiate with respect to)")
    if symbolic and lang in TRACED:
        raise SettingError("symbolic", f"applies to python, c, matlab and latex, not {lang}")
    if lang == "casadi":
        from ..output.export.casadi import require
        require()


def export(robot, lang: str, formulation: str = "kane", symbolic: bool = False,
           fragment: bool = False, timings: dict | None = None, eom=None,
           derivatives: bool = False, parameters=(), regressor: bool = False) -> ExportResult:
    """The files of ``robot``'s equations in ``lang`` (``eom``: equations already derived,
    with ``symbolic`` parameters or not as asked); ``derivatives`` (c, python): also
    the derivatives' files (``output.export.derivatives``), with respect to the
    robot file's ``parameters`` too; ``regressor`` (c, python): also the regressor's
    files (``output.export.regressor``)."""
    from ..output.export import c, latex, matlab, python
    from ..output.export import derivatives as derivative_files
    from ..output.export import regressor as regressor_files
    from ..output.export.model import ExportModel, identifier
    from ..symbolic.formulations import derive

    check_options(lang, fragment, symbolic, derivatives, parameters, regressor)
    refuse_closed_chain(robot, "export")
    timings = {} if timings is None else timings
    extra = {}
    if derivatives:             # first: a wrong parameter is refused before the closed forms
        start = time.perf_counter()
        with progress.task(f"tracing the derivatives of {robot.name}"):
            extra = derivative_files.files(robot, identifier(robot.name), lang, parameters)
        timings["derivatives"] = time.perf_counter() - start
    if regressor:               # first too: a robot the regressor does not take is refused
        start = time.perf_counter()
        with progress.task(f"tracing the regressor of {robot.name}"):
            extra.update(regressor_files.files(robot, identifier(robot.name), lang))
        timings["regressor"] = time.perf_counter() - start
    if lang in TRACED:
        return _traced(robot, lang, timings)
    start = time.perf_counter()
    if eom is None:
        eom = derive(robot, formulation, symbolic=symbolic)
    timings["derive"] = time.perf_counter() - start
    start = time.perf_counter()
    with progress.task(f"generating the {lang} files of {robot.name}") as step:
        step.note("the Jacobian's partial derivatives")
        model = ExportModel.build(robot, eom)
        if lang == "latex":
            texts = latex.files(model, fragment)
        else:
            texts = {"c": c.files, "python": python.files, "matlab": matlab.files}[lang](
                model, step.note)
    timings["generate"] = time.perf_counter() - start
    return ExportResult(lang, model, {**texts, **extra}, fragment, timings)


def _traced(robot, lang: str, timings: dict) -> ExportResult:
    from ..output.export import casadi, jax, traced

    start = time.perf_counter()
    with progress.task(f"tracing the dynamics of {robot.name}"):
        model = traced.trace(robot)
    timings["derive"] = time.perf_counter() - start
    start = time.perf_counter()
    texts = {"casadi": casadi.files, "jax": jax.files}[lang](model)
    timings["generate"] = time.perf_counter() - start
    return ExportResult(lang, model, texts, False, timings)


@output.one_set
def write(result: ExportResult, out: Path) -> list[Path]:
    """Every file, then export.json, put in place together (``files.one_set``)."""
    out = output.prepare_dir(out)
    written = []
    for name, text in result.files.items():
        written.append(out / name)
        output.write_text(written[-1], text)
    written.append(out / "export.json")
    output.write_json(written[-1], summary(result))
    return written


def summary(result: ExportResult) -> dict:
    model = result.model
    if result.lang in TRACED:
        return {"robot": model.robot_name, "lang": result.lang, "evaluator": "recursive",
                "coordinates": model.coordinates, "efforts": model.efforts,
                "functions": {name: [arg for arg, _ in f.args] for name, f in
                              model.functions.items()},
                "files": {name: {"bytes": len(text.encode("utf-8"))}
                          for name, text in result.files.items()},
                "timings": {k: v for k, v in result.timings.items() if isinstance(v, float)}}
    return {
        "robot": model.robot_name, "name": model.name, "lang": result.lang,
        "formulation": model.formulation, "evaluator": "closed-form", "symbolic": model.symbolic,
        "fragment": result.fragment, "coordinates": [c.name for c in model.coordinates],
        # the speeds u of x = [q, u] when they are not the coordinates' rates
        **({"speeds": [u.name for u in model.rates]} if model.kinematic is not None else {}),
        "efforts": [e.name for e in model.efforts], "controller": model.has_controller,
        "time_dependent": model.time_dependent,
        "parameters": {p.name: p.value for p in model.parameters},
        "files": {name: {"bytes": len(text.encode("utf-8")), "lines": text.count("\n")}
                  for name, text in result.files.items()},
        "timings": {k: v for k, v in result.timings.items() if isinstance(v, float)},
    }
