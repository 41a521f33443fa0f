"""A law as a self-contained strict C99 library for one spacecraft's controller (``fsmctl export --target c``).

The law's generated CasADi functions (the same ``SX`` graphs the engine compiles, from the same SymPy law) are
printed once more by :mod:`fsmctl.codegen.c99` as library-free C99; the controller around them
(``fsmctl/csrc/export/controller.c``: parameter checks, the neighbour aggregation of eq 19, the law state over the
control period) and the elementary functions (``fsmctl/csrc/export/export_math.c``) are copied with the library's
prefix.  Nothing is typed twice: the C structs and range checks below are printed from the law's declaration
(``law.json``).

Layout of the folder (``P`` is the prefix, the law's name by default)::

    P.h, P.c            the API: P_default_config, P_init, P_broadcast, P_step (P_wheel_commands,
                        P_trigger_margin where the law declares them)
    P_law.h, P_law.c    the law's functions, its parameters' packing and declared ranges
    P_math.h, P_math.c  pow, sqrt, exp without libm
    README.md           units, frames, the API, how to compile
    manifest.json       the law, the versions, the sha256 of every file
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import math
import re
from collections.abc import Mapping
from dataclasses import dataclass
from importlib import resources
from pathlib import Path

import casadi as ca
import sympy as sp

from fsmctl.codegen.c99 import UnsupportedExportInstructionError, c99_function, c99_signature
from fsmctl.errors import InputError
from fsmctl.model.laws import LawCode, LawError, LawParameterInfo, builtin_laws, initial_law_states, resolve_law
from fsmctl.outputs import jsonable, output_folder, write_json, write_text
from fsmctl.version import __version__

__all__ = [
    "EXPORT_FORMAT",
    "PRECISIONS",
    "ERROR_MODELS",
    "ExportError",
    "CLibrary",
    "write_c_library",
    "read_c_library",
    "strict_flags",
    "with_defaults",
    "file_sha256",
]

EXPORT_FORMAT = 1
"""Version of the exported folder's layout (``manifest.json``'s ``format``)."""

PRECISIONS = {"float64": "double", "float32": "float"}
"""The precisions of an export and their C types."""

ERROR_MODELS = ("paper", "exact")
"""The error kinematics a law is exported with (the engine's ``controller.error_model``)."""

_TEMPLATES = ("controller.c", "export_math.c", "export_math.h")


class ExportError(InputError):
    """A law cannot be exported as asked (an unknown option, an operation the C99 export cannot print).

    Examples
    --------
    >>> try:
    ...     write_c_library("pid", "out", control_period=0.01, precision="float16")
    ... except ExportError as exc:
    ...     print(exc)
    precision: must be one of float64, float32, got 'float16'
    """


@dataclass(frozen=True)
class CLibrary:
    """An exported C library (what :func:`write_c_library` wrote).

    Parameters
    ----------
    folder : pathlib.Path
        The folder.
    prefix : str
        The prefix of every C name (``P_init``, ``P_step``, ...).
    precision : str
        ``"float64"`` or ``"float32"``.
    error_model : str
        ``"paper"`` or ``"exact"``.
    law : LawCode
        The exported law.
    sources : tuple of pathlib.Path
        The C sources to compile (``P.c``, ``P_law.c``, ``P_math.c``).
    manifest : dict
        ``manifest.json``.

    Examples
    --------
    >>> lib = write_c_library("fsm", "fsm_c", control_period=0.01, precision="float32")
    >>> lib.prefix, lib.header.name, [s.name for s in lib.sources]
    ('fsm', 'fsm.h', ['fsm.c', 'fsm_law.c', 'fsm_math.c'])
    """

    folder: Path
    prefix: str
    precision: str
    error_model: str
    law: LawCode
    sources: tuple[Path, ...]
    manifest: dict

    @property
    def header(self) -> Path:
        """The public header ``P.h``."""
        return self.folder / f"{self.prefix}.h"


def strict_flags(precision: str) -> tuple[str, ...]:
    """The compiler flags the export must compile cleanly with (issue 30's bar), for ``precision``.

    Parameters
    ----------
    precision : {"float64", "float32"}
        The export's arithmetic (float32 adds ``-Wconversion``).

    Returns
    -------
    tuple of str
        The flags (strict C99, every warning an error, no floating-point contraction).

    Examples
    --------
    >>> strict_flags("float32")[-1]
    '-Wconversion'
    """
    flags = ("-std=c99", "-Wall", "-Wextra", "-Werror", "-pedantic", "-ffp-contract=off")
    return flags + (("-Wconversion",) if precision == "float32" else ())


# ----------------------------------------------------------------------------- the law's functions


def _sx_function(law: LawCode, name: str) -> ca.Function:
    return ca.Function.deserialize((law.folder / "casadi" / f"{name}.casadi").read_text())


def _function_names(law: LawCode, error_model: str) -> dict[str, str]:
    """C name suffix -> the law folder's function."""
    names = {"constants": "law_constants", "local": f"law_local_{error_model}", "control": f"law_control_{error_model}"}
    if law.n_wheels:
        names["wheels"] = f"law_wheels_{error_model}"
    if law.trigger is not None:
        names["trigger"] = "law_trigger"
    return names


def with_defaults(law: LawCode, parameters: Mapping[str, object] | None) -> LawCode:
    """``law`` with some parameters' defaults replaced (what ``fsmctl export --set`` bakes into an export).

    Parameters
    ----------
    law : LawCode
        The law.
    parameters : mapping, optional
        Parameter name -> value, as a scenario's ``[controller]`` writes it (a number, ``size`` numbers, an
        option's name); checked against the law's declaration.

    Returns
    -------
    LawCode
        The same law (its code, its folder) with those defaults.

    Raises
    ------
    LawError
        An unknown parameter or a value outside its declared range.

    Examples
    --------
    >>> from fsmctl.model import resolve_law
    >>> law = with_defaults(resolve_law("fsm"), {"alpha": 0.6, "singularity_fix": "clamp"})
    >>> law.parameter("alpha").default, law.parameter("singularity_fix").default
    ((0.6,), (2.0,))
    """
    if not parameters:
        return law
    for name in parameters:
        law.parameter(name)  # an unknown name: LawError with "did you mean"
    new = tuple(
        dataclasses.replace(p, default=p.values(parameters[p.name], f"parameter {p.name}"))
        if p.name in parameters
        else p
        for p in law.parameters
    )
    return dataclasses.replace(law, parameters=new)


def _literal(value: float, real: str) -> str:
    text = repr(float(value))
    return text if real == "double" else f"(float){text}"


def _field_name(parameter: LawParameterInfo) -> str:
    return parameter.name if parameter.size == 1 else f"{parameter.name}[{parameter.size}]"


def _component(parameter: LawParameterInfo, k: int) -> str:
    return f"p->{parameter.name}" if parameter.size == 1 else f"p->{parameter.name}[{k}]"


def _range_condition(parameter: LawParameterInfo, value: str, real: str) -> str:
    """A C condition true when ``value`` is inside ``parameter``'s declared range (and finite)."""
    if parameter.choices:
        return " || ".join(f"{value} == {_literal(k, real)}" for k in range(len(parameter.choices)))
    parts = [f"{value} - {value} == 0"]
    if parameter.minimum is not None:
        parts.append(f"{value} {'>' if parameter.exclusive_minimum else '>='} {_literal(parameter.minimum, real)}")
    if parameter.maximum is not None:
        parts.append(f"{value} {'<' if parameter.exclusive_maximum else '<='} {_literal(parameter.maximum, real)}")
    return " && ".join(parts)


def _c_string(text: str) -> str:
    return '"' + text.replace("\\", "\\\\").replace('"', '\\"') + '"'


def _parameter_code(law: LawCode, prefix: str, real: str) -> str:
    """``P_pack_parameters``, ``P_unpack_parameters``, ``P_check_parameters`` and ``P_default_parameters``."""
    pack = [f"void {prefix}_pack_parameters(const {prefix}_parameters *p, {prefix}_real *packed) {{"]
    unpack = [f"void {prefix}_unpack_parameters(const {prefix}_real *packed, {prefix}_parameters *p) {{"]
    check = [f"const char *{prefix}_check_parameters(const {prefix}_real *packed) {{"]
    defaults = [f"void {prefix}_default_parameters({prefix}_parameters *p) {{"]
    index = 0
    for parameter in law.parameters:
        for k in range(parameter.size):
            pack.append(f"  packed[{index}] = {_component(parameter, k)};")
            unpack.append(f"  {_component(parameter, k)} = packed[{index}];")
            condition = _range_condition(parameter, f"packed[{index}]", real)
            why = f"{parameter.name}: must be {parameter.range_text()}"
            check.append(f"  if (!({condition})) return {_c_string(why)};")
            defaults.append(f"  {_component(parameter, k)} = {_literal(parameter.default[k], real)};")
            index += 1
    if index == 0:
        pack.append("  (void)p;\n  (void)packed;")
        unpack.append("  (void)p;\n  (void)packed;")
        check.append("  (void)packed;")
        defaults.append("  (void)p;")
    pack.append("}")
    unpack.append("}")
    check += ["  return 0;", "}"]
    defaults.append("}")
    return "\n".join([*pack, "", *unpack, "", *check, "", *defaults]) + "\n"


def _law_source(law: LawCode, prefix: str, real: str, error_model: str) -> str:
    body = [
        f'#include "{prefix}_law.h"',
        f'#include "{prefix}_math.h"',
        "",
        f"const {prefix}_real {prefix}_initial_state[{prefix.upper()}_N_STATES_ALLOC] = {{"
        + ", ".join(_literal(v, real) for v in (initial_law_states(law).tolist() or [0.0]))
        + "};",
        "",
        _parameter_code(law, prefix, real),
    ]
    uses_infinity, docs = False, _function_docs(law)
    for suffix, name in _function_names(law, error_model).items():
        try:
            text = c99_function(f"{prefix}_law_{suffix}", _sx_function(law, name), real=real, math_prefix=prefix)
        except UnsupportedExportInstructionError as exc:
            raise ExportError(f"law {law.name!r}: {exc}") from None
        uses_infinity |= f"{real}_infinity()" in text
        body += [f"/* {name}: {docs.get(name, '')} */", text]
    if uses_infinity:
        body.insert(3, _INFINITY.format(real=real))
    return "\n".join(body)


_INFINITY = """static {real} {real}_infinity(void) {{
  union {{
    double d;
    unsigned long long u;
  }} b;
  b.u = 0x7ff0000000000000ULL;
  return ({real})b.d;
}}
"""


def _function_docs(law: LawCode) -> dict[str, str]:
    """Each generated function's one-line doc, from the law folder's manifest (read once)."""
    entries = json.loads((law.folder / "manifest.json").read_text()).get("functions", [])
    return {e["name"]: e.get("doc", "").replace("*/", "* /") for e in entries}


# ----------------------------------------------------------------------------- headers

_API = """
/* Status codes (P_status_text) */
enum {{
  {PU}_STATUS_OK = 0,
  {PU}_STATUS_BAD_PARAMETER = 1, /* P_init: a law parameter outside its declared range (P_error_text names it) */
  {PU}_STATUS_BAD_CONFIG = 2,    /* P_init: J0, torque_limit, control_period or law_state_substeps */
  {PU}_STATUS_BAD_INPUT = 3,     /* a non-finite input, a negative neighbour count */
  {PU}_STATUS_NONFINITE = 4,     /* the law commanded a non-finite torque (the command must not be applied) */
  {PU}_STATUS_NOT_READY = 5      /* P_step without P_broadcast at this instant (or P_wheel_commands without P_step) */
}};

/* What the spacecraft knows at a control instant */
typedef struct {{
  {P}_real t;              /* time (s) */
  {P}_real sigma[3];       /* measured attitude: MRP of the body frame B relative to the inertial frame N */
  {P}_real omega[3];       /* measured body rate of B relative to N (rad/s, in B) */
  {P}_real sigma_d[3];     /* reference attitude: MRP of the reference frame D relative to N */
  {P}_real omega_d[3];     /* reference rate of D relative to N (rad/s, in D) */
  {P}_real omega_d_dot[3]; /* its derivative (rad/s^2, in D) */
}} {P}_input;

/* What the neighbours sent (incoming links, in any fixed order) */
typedef struct {{
  int count;                  /* incoming links (0: no neighbours) */
  const {P}_real *broadcast;  /* count x {PU}_N_BROADCAST: each neighbour's last broadcast */
  const {P}_real *k_own;      /* count: the link's k^i_ij (Liang et al. 2012 eq 19) */
  const {P}_real *k_sender;   /* count: its k^j_ij(t) at this instant (0: the link is off) */
}} {P}_neighbours;

/* What step() commands */
typedef struct {{
  {P}_real torque[3];                       /* torque command (N m, body frame), limited per axis */
  {P}_real torque_commanded[3];             /* the law's command before the limit (N m) */
  {P}_real z_dot[{PU}_N_STATES_ALLOC];      /* the law state's derivative at this instant */
  {P}_real z[{PU}_N_STATES_ALLOC];          /* the law state after the control period */
}} {P}_command;

typedef struct {{
  {P}_parameters parameters;    /* the law's parameters (P_default_config: the declared defaults) */
  {P}_real J0[9];               /* nominal inertia (kg m^2, body frame, row-major): symmetric positive definite */
  {P}_real torque_limit;        /* per-axis torque limit u_max (N m) > 0; +inf: none */
  {P}_real control_period;      /* h (s) > 0: each step() advances the law state over law_state_substeps h */
  int law_state_substeps;       /* >= 1 (1 on a flight computer; the engine's steps per control period for the
                                   software-in-the-loop check: the same bits) */
}} {P}_config;

/* One spacecraft's controller: caller-owned, all its state inside (no globals, no allocation) */
typedef struct {{
  {P}_config config;
  {P}_real params[{PU}_N_PARAMETERS_ALLOC];
  {P}_real constants[{PU}_N_CONSTANTS_ALLOC];
  {P}_real z[{PU}_N_STATES_ALLOC];
  {P}_real z_used[{PU}_N_STATES_ALLOC];
  {P}_real cache[{PU}_N_CACHE_ALLOC];
  {P}_real received[{PU}_N_BROADCAST];
  {P}_real k_sum, k_received_sum;
  {P}_input input;
  int ready, stepped;
  const char *error;
}} {P}_controller;

/* The exported defaults of the law's parameters (its declared ones unless set at export), J0 = 0 (set it), the
 * exported torque limit (+inf: none), the exported control period, one substep. */
void {P}_default_config({P}_config *config);
/* Check config (every parameter against its declared range) and start the controller: the law state at its
 * declared initial value.  Returns {PU}_STATUS_OK, {PU}_STATUS_BAD_PARAMETER or {PU}_STATUS_BAD_CONFIG (P_error_text says which). */
int {P}_init({P}_controller *controller, const {P}_config *config);
/* Phase 1 of a control instant: what this spacecraft sends its neighbours, from its measurement and reference. */
int {P}_broadcast({P}_controller *controller, const {P}_input *input, {P}_real broadcast[{PU}_N_BROADCAST]);
/* Phase 2, once per broadcast(): the torque from the same input and the neighbours' broadcasts; advances the law
 * state over the control period.  Returns {PU}_STATUS_OK, {PU}_STATUS_NOT_READY, {PU}_STATUS_BAD_INPUT or {PU}_STATUS_NONFINITE. */
int {P}_step({P}_controller *controller, const {P}_neighbours *neighbours, {P}_command *command);
/* Set the law state (e.g. after a reset of the integrator); init() sets the declared initial value. */
int {P}_reset_state({P}_controller *controller, const {P}_real z[{PU}_N_STATES_ALLOC]);
const char *{P}_status_text(int status);
const char *{P}_error_text(const {P}_controller *controller);
"""

_WHEELS_API = """
/* The law's own per-wheel motor torque commands (N m; positive spins wheel k up along its axis) after step(), for
 * the wheels' spin axes (3 x {PU}_N_WHEELS: axis k at [3k, 3k + 2], body frame, unit), speeds (rad/s) and spin
 * inertias (kg m^2). */
int {P}_wheel_commands(const {P}_controller *controller, const {P}_real spin_axes[3 * {PU}_N_WHEELS],
                       const {P}_real wheel_speed[{PU}_N_WHEELS], const {P}_real spin_inertia[{PU}_N_WHEELS],
                       {P}_real u_wheels[{PU}_N_WHEELS]);
"""

_TRIGGER_API = """
/* The law's event trigger: send the broadcast when the margin is > 0 (broadcast_sent: the last one sent). */
{P}_real {P}_trigger_margin(const {P}_controller *controller, {P}_real t,
                            const {P}_real broadcast[{PU}_N_BROADCAST],
                            const {P}_real broadcast_sent[{PU}_N_BROADCAST]);
"""


def _alloc(n: int) -> int:
    return max(n, 1)  # C99 has no zero-length arrays


def _public_header(law: LawCode, prefix: str, real: str, precision: str, error_model: str, period: float) -> str:
    P, PU = prefix, prefix.upper()
    sizes = {
        "N_PARAMETERS": law.n_params,
        "N_STATES": law.n_states,
        "N_BROADCAST": law.n_broadcast,
        "N_CONSTANTS": law.n_constants,
        "N_CACHE": law.n_cache,
        "N_WHEELS": law.n_wheels,
    }
    lines = [
        "/*",
        f" * {P}: the control law {law.name!r} for one spacecraft, exported by fsmctl {__version__}",
        f" * ({precision}, {error_model} error kinematics).  {law.doc}",
        *([f" * Reference: {law.reference}"] if law.reference else []),
        " * DO NOT EDIT: written by `fsmctl export`; regenerate it from the law.  See README.md.",
        " */",
        f"#ifndef {PU}_H",
        f"#define {PU}_H",
        "",
        "#ifdef __cplusplus",
        'extern "C" {',
        "#endif",
        "",
        f"typedef {real} {P}_real;",
        "",
    ]
    for key, value in sizes.items():
        lines.append(f"#define {PU}_{key} {value}")
        if key != "N_BROADCAST" and key != "N_WHEELS":
            lines.append(f"#define {PU}_{key}_ALLOC {_alloc(value)}")
    lines += [f"#define {PU}_HAS_TRIGGER {int(law.trigger is not None)}"]
    lines += [
        f'#define {PU}_LAW_NAME "{law.name}"',
        f'#define {PU}_LAW_MANIFEST_SHA256 "{file_sha256(law.folder / "manifest.json")}" /* the law folder it came from */',
        f'#define {PU}_FSMCTL_VERSION "{__version__}"',
    ]
    lines += [f"#define {PU}_DEFAULT_CONTROL_PERIOD {float(period)!r} /* s */", ""]
    for parameter in law.parameters:
        for k, choice in enumerate(parameter.choices):
            word = re.sub(r"\W", "_", choice).upper()
            lines.append(f"#define {PU}_{parameter.name.upper()}_{word} {k}")
    lines += ["", "/* The law's parameters (declaration order; units and ranges as declared) */", "typedef struct {"]
    for parameter in law.parameters:
        unit = f"{parameter.unit}; " if parameter.unit not in ("", "1") else ""
        lines.append(f"  {P}_real {_field_name(parameter)}; /* {unit}{parameter.range_text()}: {parameter.doc} */")
    if not law.parameters:
        lines.append(f"  {P}_real unused; /* the law has no parameters */")
    lines += [f"}} {P}_parameters;"]
    text = "\n".join(lines) + "\n" + _API.format(P=P, PU=PU)
    text += _WHEELS_API.format(P=P, PU=PU) if law.n_wheels else ""
    text += _TRIGGER_API.format(P=P, PU=PU) if law.trigger is not None else ""
    return text + f"\n#ifdef __cplusplus\n}}\n#endif\n#endif /* {PU}_H */\n"


def _law_header(law: LawCode, prefix: str, error_model: str) -> str:
    P, PU = prefix, prefix.upper()
    lines = [
        f"/* {P}_law: the law's generated functions (internal to the library; see {P}.h).",
        " * DO NOT EDIT: written by `fsmctl export` (fsmctl/codegen/c99.py) from the law's CasADi graphs. */",
        f"#ifndef {PU}_LAW_H",
        f"#define {PU}_LAW_H",
        "",
        f'#include "{P}.h"',
        "",
        f"extern const {P}_real {P}_initial_state[{PU}_N_STATES_ALLOC];",
        f"void {P}_pack_parameters(const {P}_parameters *p, {P}_real *packed);",
        f"void {P}_unpack_parameters(const {P}_real *packed, {P}_parameters *p);",
        f"const char *{P}_check_parameters(const {P}_real *packed);",
        f"void {P}_default_parameters({P}_parameters *p);",
    ]
    lines += [c99_signature(f"{P}_law_{suffix}", f"{P}_real") + ";" for suffix in _function_names(law, error_model)]
    lines += ["", f"#endif /* {PU}_LAW_H */", ""]
    return "\n".join(lines)


_DEFAULT_CONFIG = """void {P}_default_config({P}_config *config) {{
  union {{
    double d;
    unsigned long long u;
  }} inf;
  int k;
  inf.u = 0x7ff0000000000000ULL;
  (void)inf;
  {P}_default_parameters(&config->parameters);
  for (k = 0; k < 9; ++k) config->J0[k] = 0;
  config->torque_limit = {torque_limit};
  config->control_period = ({P}_real){PU}_DEFAULT_CONTROL_PERIOD;
  config->law_state_substeps = 1;
}}
"""


# ----------------------------------------------------------------------------- README and manifest

_README = """# {P}: the control law `{law}` for one spacecraft (C99)

Exported by fsmctl {version} with `{command}`.
{doc}
{reference}
Precision **{precision}** (`{P}_real` is `{real}`), **{error_model}** error kinematics, default control period
{period} s.  Do not edit these files: export the law again (`manifest.json` has the sha256 of each).

## What it is
Strict C99: no dynamic allocation, no global mutable state (all state in the caller-owned `{P}_controller`), no
dependency beyond the C language itself (no libm: `{P}_math.c` has the law's `pow`, `sqrt`, `exp`).  It compiles
with `gcc` or `clang` at `{flags}`, and with `-ffreestanding`.
**Compile without floating-point contraction** (`-ffp-contract=off`, GCC's default with `-std=c99`): a fused
multiply-add changes results (not their accuracy), and the bit-for-bit check against fsmctl's engine assumes none.

    cc -std=c99 -O2 -ffp-contract=off -c {P}.c {P}_law.c {P}_math.c

## Units and frames
- `sigma`: the modified Rodrigues parameters (MRP) of the body frame B relative to the inertial frame N (any set:
  the law switches nothing, the caller may pass the shadow set); `omega`: the body rate of B relative to N in B
  (rad/s).
- `sigma_d`, `omega_d`, `omega_d_dot`: the reference frame D's MRP relative to N, its rate (rad/s) and acceleration
  (rad/s^2) in D.
- `torque`: the control torque on the body (N m, B), limited per axis to `torque_limit`.
- The broadcast: `{broadcast}` ({nb} numbers, unit {broadcast_unit}), what each spacecraft sends its neighbours.
- `J0`: the nominal inertia (kg m^2, B, row-major).  The law's parameters:

| parameter | size | unit | range | default | meaning |
|---|---|---|---|---|---|
{parameter_rows}

## Every control instant t_q (period h = `control_period`)
1. `{P}_broadcast(&c, &input, b)`: from the measured attitude and rate and the reference at t_q; send `b`.
2. Receive the neighbours' broadcasts of t_q with their weights (`{P}_neighbours`: k^i_ij and k^j_ij(t_q) of Liang
   et al. 2012 eq 19, link by link).
3. `{P}_step(&c, &neighbours, &command)`: apply `command.torque` until t_q + h; the law state advances over
   `law_state_substeps` steps of h (use 1 on a flight computer; fsmctl's software-in-the-loop check uses the
   engine's steps per control period to compare bits).

```c
#include "{P}.h"

{P}_controller c;
{P}_config config;
{P}_default_config(&config);                 /* the law's declared defaults */
/* config.J0[0] = ...; config.torque_limit = ...; config.parameters.<name> = ...; */
if ({P}_init(&c, &config) != {PU}_STATUS_OK) /* {P}_error_text(&c) names the bad field */;

{P}_input in;                                /* t, sigma, omega, sigma_d, omega_d, omega_d_dot */
{P}_real b[{PU}_N_BROADCAST];
{P}_broadcast(&c, &in, b);
{P}_neighbours nb = {{0, 0, 0, 0}};          /* count, broadcast (count x {PU}_N_BROADCAST), k_own, k_sender */
{P}_command cmd;
int status = {P}_step(&c, &nb, &cmd);        /* {PU}_STATUS_NONFINITE: do not apply cmd.torque */
```

The neighbours: one entry per incoming link, in any fixed order: the broadcast that neighbour sent at this instant,
`k_own` = k^i_ij (the receiving spacecraft's coupling gain for that link) and `k_sender` = k^j_ij(t) (the link's
weight now; 0 when the link is off). An always-on link of the paper's Case 1 has k_own = 8, k_sender = 5; a plain
unit link 1 and 1. With no neighbours, `count = 0`.
{extras}
## Status codes
Every function returns one (`{P}_status_text(status)` says it in words; after a failed `{P}_init`,
`{P}_broadcast` or `{P}_step`, `{P}_error_text(&c)` names what was wrong):

| code | value | meaning |
|---|---|---|
| `{PU}_STATUS_OK` | 0 | done |
| `{PU}_STATUS_BAD_PARAMETER` | 1 | `init`: a law parameter outside its declared range |
| `{PU}_STATUS_BAD_CONFIG` | 2 | `init`: J0 (finite, symmetric, positive definite), `torque_limit` (> 0), `control_period` (> 0) or `law_state_substeps` (>= 1) |
| `{PU}_STATUS_BAD_INPUT` | 3 | a non-finite input or weight, a negative neighbour count |
| `{PU}_STATUS_NONFINITE` | 4 | the law commanded a non-finite torque: do not apply it |
| `{PU}_STATUS_NOT_READY` | 5 | `step` without `broadcast` at this instant (or `wheel_commands` without `step`) |

`{P}_default_config` sets the parameters' defaults of the table above (the law's declared ones unless set at
export: {defaults_set}), `J0` = 0 (you must set it), `torque_limit` = {torque_limit} N m, the exported control
period ({period} s) and one law-state substep.
"""


def _parameter_rows(law: LawCode) -> str:
    rows = []
    for p in law.parameters:
        default = p.default_text() if not p.choices else f"{p.default_text()} ({int(p.default[0])})"
        choices = " \\| ".join(f"{c} = {k}" for k, c in enumerate(p.choices)) if p.choices else p.range_text()
        doc = p.doc.replace("|", "\\|")
        rows.append(f"| `{p.name}` | {p.size} | {p.unit} | {choices} | {default} | {doc} |")
    return "\n".join(rows) if rows else "| (none) | | | | | |"


def _readme(
    law: LawCode, prefix: str, precision: str, error_model: str, period: float, command: str, limit: float, set_: list
) -> str:
    extras = []
    if law.n_wheels:
        extras.append(
            f"The law commands its {law.n_wheels} reaction wheels: after `{prefix}_step`, `{prefix}_wheel_commands` "
            "gives each wheel's motor torque (N m) from the wheels' spin axes, speeds and spin inertias.\n"
        )
    if law.trigger is not None:
        extras.append(
            f"Event-triggered communication: send the broadcast only when `{prefix}_trigger_margin(&c, t, b, "
            "b_sent) > 0` (`b_sent`: what was sent last); the neighbours keep the last message they received.\n"
        )
    return _README.format(
        P=prefix,
        PU=prefix.upper(),
        law=law.name,
        version=__version__,
        command=command,
        doc=law.doc,
        reference=f"Reference: {law.reference}.\n" if law.reference else "",
        precision=precision,
        real=PRECISIONS[precision],
        error_model=error_model,
        period=repr(float(period)),
        flags=" ".join(strict_flags(precision)),
        broadcast=law.broadcast_name,
        nb=law.n_broadcast,
        broadcast_unit=law.broadcast_unit,
        parameter_rows=_parameter_rows(law),
        extras="\n" + "\n".join(extras) if extras else "",
        defaults_set=", ".join(f"`{n}`" for n in set_) or "none was",
        torque_limit="+inf (none)" if math.isinf(limit) else repr(float(limit)),
    )


def file_sha256(path: Path) -> str:
    """The hex sha256 of a file (the manifests' digests)."""
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _check_options(law: LawCode, prefix: str, precision: str, error_model: str, period: float) -> None:
    if precision not in PRECISIONS:
        raise ExportError(f"precision: must be one of {', '.join(PRECISIONS)}, got {precision!r}")
    if error_model not in ERROR_MODELS:
        raise ExportError(f"error model: must be one of {', '.join(ERROR_MODELS)}, got {error_model!r}")
    if not re.fullmatch(r"[A-Za-z][A-Za-z0-9_]{0,30}", prefix):
        raise ExportError(f"prefix: must be a C identifier of at most 31 characters, got {prefix!r}")
    if not (isinstance(period, (int, float)) and period > 0 and period < float("inf")):
        raise ExportError(f"control period: must be a finite number > 0 s, got {period!r}")


def write_c_library(
    law: str | Path | LawCode,
    out_dir: str | Path,
    *,
    control_period: float,
    precision: str = "float64",
    error_model: str = "exact",
    prefix: str | None = None,
    parameters: Mapping[str, object] | None = None,
    torque_limit: float = math.inf,
    command: str = "fsmctl.export.write_c_library",
) -> CLibrary:
    """Write one spacecraft's controller for ``law`` as a self-contained strict C99 library.

    Parameters
    ----------
    law : str, path or LawCode
        A built-in law's name, a derivation script or law folder (:func:`fsmctl.model.resolve_law`).
    out_dir : path
        The folder (created; files of an earlier export with the same prefix are replaced).
    control_period : float
        The default control period h (s) of ``P_default_config``.
    precision : {"float64", "float32"}
        The arithmetic of the library.
    error_model : {"exact", "paper"}
        The error kinematics of the law variant exported (the engine's ``controller.error_model``).
    prefix : str, optional
        The prefix of every C name (default: the law's name).
    parameters : mapping, optional
        Defaults that replace the law's declared ones (:func:`with_defaults`): what ``P_default_config`` sets.
    torque_limit : float
        The default torque limit (N m; ``inf``: none).
    command : str
        What the README says wrote the folder.

    Returns
    -------
    CLibrary
        The folder, its sources and manifest.

    Raises
    ------
    ExportError
        An unknown precision or error model, a prefix that is not a C identifier, a control period that is not
        a positive number, or an operation the C99 export cannot print.
    LawError
        ``law`` is not a law.

    Examples
    --------
    >>> lib = write_c_library("pid", "pid_c", control_period=0.01)
    >>> sorted(p.name for p in lib.folder.iterdir())  # doctest: +NORMALIZE_WHITESPACE
    ['README.md', 'manifest.json', 'pid.c', 'pid.h', 'pid_law.c', 'pid_law.h', 'pid_math.c', 'pid_math.h']
    >>> lib.manifest["law"]["name"], lib.manifest["precision"]
    ('pid', 'float64')
    """
    code = with_defaults(resolve_law(law) if not isinstance(law, LawCode) else law, parameters)
    prefix = prefix or code.name
    _check_options(code, prefix, precision, error_model, control_period)
    if not (torque_limit > 0):
        raise ExportError(f"torque limit: must be > 0 N m (inf: none), got {torque_limit!r}")
    limit = "(" + prefix + "_real)inf.d" if math.isinf(torque_limit) else _literal(torque_limit, PRECISIONS[precision])
    real = PRECISIONS[precision]
    P, PU = prefix, prefix.upper()
    texts = {
        f"{P}.h": _public_header(code, P, real, precision, error_model, control_period),
        f"{P}_law.h": _law_header(code, P, error_model),
        f"{P}_law.c": _law_source(code, P, real, error_model)
        + "\n"
        + _DEFAULT_CONFIG.format(P=P, PU=PU, torque_limit=limit),
    }
    templates = resources.files("fsmctl") / "csrc" / "export"
    names = {"controller.c": f"{P}.c", "export_math.c": f"{P}_math.c", "export_math.h": f"{P}_math.h"}
    for template in _TEMPLATES:
        texts[names[template]] = (templates / template).read_text().replace("@PU@", PU).replace("@P@", P)
    texts["README.md"] = _readme(
        code, P, precision, error_model, control_period, command, torque_limit, sorted(parameters or {})
    )
    with output_folder(out_dir) as folder:
        for name, text in texts.items():
            write_text(folder / name, text)
        law_manifest = json.loads((code.folder / "manifest.json").read_text())
        manifest = {
            "_comment": "DO NOT EDIT: written by `fsmctl export`",
            "format": EXPORT_FORMAT,
            "law": {
                "name": code.name,
                "source": code.script(portable=True),
                "manifest_sha256": file_sha256(code.folder / "manifest.json"),
                "functions": _function_names(code, error_model),
            },
            "prefix": P,
            "precision": precision,
            "error_model": error_model,
            "control_period": float(control_period),
            "defaults_set": {k: list(code.parameter(k).default) for k in sorted(parameters or {})},
            "torque_limit": float(torque_limit),
            "versions": {"fsmctl": __version__, **law_manifest.get("versions", {}), "sympy_installed": sp.__version__},
            "sha256": {name: file_sha256(folder / name) for name in sorted(texts)},
        }
        manifest = jsonable(manifest)  # strict JSON, as read back: an infinite torque limit is "inf"
        write_json(folder / "manifest.json", manifest)
    sources = tuple(folder / n for n in (f"{P}.c", f"{P}_law.c", f"{P}_math.c"))
    return CLibrary(folder, P, precision, error_model, code, sources, manifest)


def read_c_library(folder: str | Path, law: str | Path | LawCode | None = None) -> CLibrary:
    """An exported library from its folder (its ``manifest.json``), e.g. to verify it again.

    Parameters
    ----------
    folder : path
        A folder written by :func:`write_c_library` (``fsmctl export --target c``).
    law : str, path or LawCode, optional
        The exported law (default: the built-in law of that name, else the script the manifest names).

    Returns
    -------
    CLibrary
        The library as it is now (its files are not checked against the manifest here).

    Raises
    ------
    ExportError
        The folder holds no export of this format, or its law is no longer available.

    Examples
    --------
    >>> lib = write_c_library("pid", "pid_c", control_period=0.01)
    >>> read_c_library("pid_c").manifest == lib.manifest
    True
    """
    folder = Path(folder)
    try:
        manifest = json.loads((folder / "manifest.json").read_text())
        prefix, precision = manifest["prefix"], manifest["precision"]
        error_model, law_name = manifest["error_model"], manifest["law"]["name"]
        fmt = manifest["format"]
    except (OSError, ValueError, KeyError, TypeError):
        raise ExportError(
            f"{folder}: not a folder written by `fsmctl export --target c` (no readable manifest.json)"
        ) from None
    if fmt != EXPORT_FORMAT:
        raise ExportError(f"{folder}: export format {fmt}, this fsmctl reads {EXPORT_FORMAT}; export the law again")
    if law is None:
        source = manifest["law"].get("source", "")
        try:
            law = resolve_law(law_name if law_name in builtin_laws() else source)
        except LawError:
            raise ExportError(
                f"{folder}: its law {law_name!r} ({source}) is not found from here: pass law= (its script or folder)"
            ) from None
    elif not isinstance(law, LawCode):
        law = resolve_law(law)
    sources = tuple(folder / n for n in (f"{prefix}.c", f"{prefix}_law.c", f"{prefix}_math.c"))
    return CLibrary(folder, prefix, precision, error_model, law, sources, manifest)
