"""Control laws at run time: the built-in ones, a derived folder, or a derivation script.

:func:`resolve_law` turns what a user names (``--law``, ``[controller] law = ...``) into a :class:`LawCode`:

* a built-in name (``fsmctl laws`` lists them): ``generated/laws/<name>/``;
* a folder written by ``fsmctl derive FILE.py --out DIR``: it holds ``law.json`` and the generated code;
* a derivation script ``FILE.py``: derived on first use into the cache (``$FSMCTL_CACHE_DIR/laws`` or
  ``~/.cache/fsmctl/laws``), keyed by the script's content and the SymPy/CasADi/fsmctl versions.

:func:`parameter_matrix` is the one place a scenario's values become a law's packed parameters
(``[controller]`` keys by name, an agent's ``delta`` for a law with a ``delta`` parameter, else the law's
defaults), checked against the law's declared ranges.
"""

from __future__ import annotations

import functools
import hashlib
import json
import os
import shutil
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from fsmctl import __version__
from fsmctl.errors import InputError
from fsmctl.model.generated_code import GeneratedCodeError, _cache_root, generated_dir
from fsmctl.ranges import ParameterRange

__all__ = [
    "LawCode",
    "LawParameterInfo",
    "LawError",
    "builtin_laws",
    "resolve_law",
    "parameter_matrix",
    "initial_law_states",
]

LAW_FILE = "law.json"


class LawError(InputError):
    """A law cannot be found, derived or used (exit 2 on the command line)."""


@dataclass(frozen=True)
class LawParameterInfo(ParameterRange):
    """A law parameter as declared by its derivation script (from ``law.json``)."""

    name: str
    default: tuple[float, ...]
    unit: str
    minimum: float | None
    maximum: float | None
    exclusive_minimum: bool
    exclusive_maximum: bool
    choices: tuple[str, ...]
    tunable: bool
    doc: str

    def values(self, value, where: str) -> tuple[float, ...]:
        """A scenario value for this parameter, checked and packed (an option becomes its index)."""
        if self.choices:
            if not isinstance(value, str) or value.lower() not in self.choices:
                raise LawError(f"{where}: must be one of {', '.join(self.choices)}, got {value!r}")
            return (float(self.choices.index(value.lower())),)
        items = list(value) if isinstance(value, (list, tuple, np.ndarray)) else [value]
        if self.size == 1 and len(items) == 1 and isinstance(value, (list, tuple, np.ndarray)):
            raise LawError(f"{where}: expected a number, got a list")
        if len(items) != self.size:
            raise LawError(f"{where}: expected {self.size} numbers, got {len(items)}")
        out = []
        for v in items:
            if isinstance(v, bool) or not isinstance(v, (int, float, np.integer, np.floating)):
                raise LawError(f"{where}: expected a number, got {v!r}")
            why = self.problem(float(v))
            if why:
                raise LawError(f"{where}: {why}")
            out.append(float(v))
        return tuple(out)


@dataclass(frozen=True)
class LawCode:
    """A law's generated code and what the runtime needs to know about it."""

    name: str
    folder: Path
    doc: str
    reference: str
    source: str
    parameters: tuple[LawParameterInfo, ...]
    states: tuple[dict, ...]
    broadcast_name: str
    broadcast_unit: str
    n_broadcast: int
    n_constants: int
    n_cache: int
    has_lyapunov: bool

    @property
    def n_params(self) -> int:
        return sum(p.size for p in self.parameters)

    @property
    def n_states(self) -> int:
        return sum(int(s["size"]) for s in self.states)

    @property
    def builtin(self) -> bool:
        return self.folder.parent == (generated_dir() / "laws").resolve()

    def parameter(self, name: str) -> LawParameterInfo:
        for p in self.parameters:
            if p.name == name:
                return p
        raise KeyError(name)

    def state_labels(self) -> list[str]:
        out = []
        for s in self.states:
            out += [f"{s['name']}[{k}]" for k in range(int(s["size"]))] if int(s["size"]) > 1 else [s["name"]]
        return out

    def casadi(self, name: str):
        """One of the law's generated functions (compiled if possible, else CasADi's virtual machine)."""
        from fsmctl.model.generated_code import law_casadi_function

        return law_casadi_function(self.folder, name)


def _read_law(folder: Path) -> LawCode:
    try:
        meta = json.loads((folder / LAW_FILE).read_text("utf-8"))
    except FileNotFoundError:
        raise LawError(
            f"{folder}: not a law folder (no {LAW_FILE}; write one with `fsmctl derive FILE.py --out DIR`)"
        ) from None
    except (OSError, ValueError) as exc:
        raise LawError(f"{folder}/{LAW_FILE}: cannot be read ({exc})") from exc
    for f in ("manifest.json",):
        if not (folder / f).is_file():
            raise LawError(f"{folder}: incomplete law folder ({f} missing); derive it again")
    params = tuple(
        LawParameterInfo(
            p["name"],
            tuple(float(v) for v in (p["default"] if isinstance(p["default"], list) else [p["default"]])),
            p["unit"],
            p["minimum"],
            p["maximum"],
            p["exclusive_minimum"],
            p["exclusive_maximum"],
            tuple(p["choices"]),
            p["tunable"],
            p["doc"],
        )
        for p in meta["parameters"]
    )
    return LawCode(
        name=meta["name"],
        folder=folder.resolve(),
        doc=meta["doc"],
        reference=meta.get("reference", ""),
        source=meta.get("source", ""),
        parameters=params,
        states=tuple(meta["states"]),
        broadcast_name=meta["broadcast"]["name"],
        broadcast_unit=meta["broadcast"].get("unit", "1"),
        n_broadcast=int(meta["broadcast"]["size"]),
        n_constants=sum(int(c["size"]) for c in meta["constants"]),
        n_cache=sum(int(c["size"]) for c in meta["cache"]),
        has_lyapunov=meta.get("lyapunov") is not None,
    )


def builtin_laws() -> dict[str, LawCode]:
    """The built-in laws by name, in a fixed order (the paper's first)."""
    root = generated_dir() / "laws"
    folders = sorted((p for p in root.iterdir() if (p / LAW_FILE).is_file()), key=lambda p: (p.name != "fsm", p.name))
    return {p.name: _read_law(p) for p in folders}


def _law_cache_root() -> Path:
    return _cache_root() / "laws"


def _script_key(path: Path) -> str:
    import casadi
    import sympy

    h = hashlib.sha256(path.read_bytes())
    h.update(f"fsmctl {__version__} sympy {sympy.__version__} casadi {casadi.__version__}".encode())
    for p in sorted((Path(__file__).resolve().parents[1] / "symbolic").glob("*.py")) + sorted(
        (Path(__file__).resolve().parents[1] / "codegen").glob("*.py")
    ):
        h.update(p.read_bytes())  # the symbolic API and the generator determine the generated code
    return h.hexdigest()[:24]


def derive_script(path: Path, out: Path | None = None) -> Path:
    """Derive a script into ``out`` (default: the law cache, reused while the script is unchanged)."""
    from fsmctl.codegen.laws import load_derivation_script, write_law

    path = Path(path)
    if out is None:
        target = _law_cache_root() / _script_key(path)
        if (target / LAW_FILE).is_file() and (target / "manifest.json").is_file():
            return target
    else:
        target = Path(out)
    variants = load_derivation_script(path)
    target.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{target.name}.", dir=target.parent))
    try:
        write_law(tmp, variants, source=path.name, generator=f"fsmctl derive {path.name}")
        if target.exists():
            if out is not None and not (target / LAW_FILE).is_file() and any(target.iterdir()):
                raise LawError(f"{target}: exists and is not a law folder; choose another --out")
            shutil.rmtree(target)
        os.replace(tmp, target)
    finally:
        if tmp.exists():
            shutil.rmtree(tmp, ignore_errors=True)
    return target


@functools.cache
def _resolve(text: str, cwd: str) -> LawCode:
    laws = builtin_laws()
    if text in laws:
        return laws[text]
    path = Path(text).expanduser()
    if not path.is_absolute():
        path = Path(cwd) / path
    if path.is_dir():
        return _read_law(path)
    if path.suffix == ".py":
        if not path.is_file():
            raise LawError(f"law {text!r}: no such derivation script ({path})")
        return _read_law(derive_script(path))
    raise LawError(
        f"law {text!r}: not a built-in law ({', '.join(laws)}), a derivation script (.py) or a derived law folder"
    )


def resolve_law(law: str | Path | LawCode | None) -> LawCode:
    """The :class:`LawCode` of a built-in name, a derived folder or a derivation script (see the module docstring).

    Raises
    ------
    LawError
        Unknown name or missing path.
    fsmctl.symbolic.law.LawDefinitionError
        A script that does not import or breaks the law contract (both are :class:`~fsmctl.errors.InputError`).
    """
    if isinstance(law, LawCode):
        return law
    text = "fsm" if law is None else str(law)
    try:
        return _resolve(text, os.getcwd())
    except GeneratedCodeError as exc:
        raise LawError(str(exc)) from exc
    except OSError as exc:
        raise LawError(f"law {text!r}: {exc}") from exc


resolve_law.cache_clear = _resolve.cache_clear  # type: ignore[attr-defined]


def parameter_matrix(law: LawCode, scenario) -> np.ndarray:
    """The law's packed parameters for every agent, ``(n_agents, n_params)``: the one place they are resolved.

    Values come from the scenario's ``[controller]`` (the paper's typed keys c1, c2, alpha, boundary_layer,
    epsilon, singularity_fix with the ``surface`` applied, and ``controller.parameters`` by name), an agent's
    ``delta`` for a law with a ``delta`` parameter, else the law's declared defaults; each is checked against
    the declared range.

    Raises
    ------
    LawError
        A value outside its range, of the wrong size, or a parameter the law does not declare.
    """
    c = scenario.controller
    given = dict(c.parameters)
    unknown = sorted(set(given) - {p.name for p in law.parameters})
    if unknown:
        names = ", ".join(p.name for p in law.parameters) or "none"
        raise LawError(f"controller: the law {law.name!r} has no parameter {unknown[0]!r} (its parameters: {names})")
    typed = c.typed_law_parameters()
    rows = []
    for index, agent in enumerate(scenario.agents):
        row: list[float] = []
        for p in law.parameters:
            if p.name == "delta" and p.size == 3:
                value, where = agent.delta, f"agents[{index}].delta"
            elif p.name in given:
                value, where = given[p.name], f"controller.{p.name}"
            elif p.name in typed:
                value, where = typed[p.name], f"controller.{p.name}"
            else:
                row.extend(p.default)
                continue
            row.extend(p.values(value, where))
        rows.append(row)
    return np.array(rows, dtype=float).reshape(len(scenario.agents), law.n_params)


def initial_law_states(law: LawCode) -> np.ndarray:
    """The law states' declared initial values, ``(n_states,)``."""
    return np.array([v for s in law.states for v in s["initial"]], dtype=float)
