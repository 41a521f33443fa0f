"""``fsmctl export --target c``: the exported C99 library compiles strictly, runs without libm, checks its parameters,
and flies in the engine bit for bit (software in the loop).

Oracles: the engine's own law (the same CasADi graphs through the engine's CasADi-generated C) for the
software-in-the-loop flights; Python's ``math`` (C99 Annex F, correctly rounded ``sqrt``) and the engine's compiled
``fsmctl_pow`` for the elementary functions; a C harness (not Python) for the API's behaviour.
"""

from __future__ import annotations

import ctypes
import json
import math
import shutil
import subprocess
import sys
import warnings

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import fsmctl
from fsmctl.codegen.c99 import UnsupportedExportInstructionError, c99_function
from fsmctl.export import (
    BuildError,
    ExportError,
    compile_export,
    read_c_library,
    verify_export,
    write_c_library,
)
from fsmctl.model.generated_code import c_compiler, compiled_library

LAWS = ("fsm", "pid", "super_twisting", "adaptive_fsm", "fsm_event", "fsm_wheels", "docs/examples/my_law.py")

pytestmark = pytest.mark.skipif(c_compiler() is None, reason="no C compiler")


def _clang() -> list[str] | None:
    """clang: on the PATH, or zig's (the ``ziglang`` wheel of the test extra)."""
    if shutil.which("clang"):
        return [shutil.which("clang")]
    try:
        import ziglang  # noqa: F401
    except ImportError:
        return None
    return [sys.executable, "-m", "ziglang", "cc"]


@pytest.fixture(scope="module")
def exports(tmp_path_factory):
    root = tmp_path_factory.mktemp("exports")
    out = {}
    for law in LAWS:
        for precision in ("float64", "float32"):
            name = law.rsplit("/", 1)[-1].removesuffix(".py")
            out[law, precision] = write_c_library(
                law, root / f"{name}-{precision}", control_period=0.01, precision=precision, error_model="paper"
            )
    return out


@pytest.mark.parametrize("law", LAWS)
@pytest.mark.parametrize("precision", ["float64", "float32"])
def test_compiles_strictly_freestanding_without_libraries(exports, tmp_path, law, precision):
    """gcc at -std=c99 -Wall -Wextra -Werror -pedantic (-Wconversion in float32), -ffreestanding; the objects need
    no symbol from outside the library (no libm, no libc: nm lists only the library's own)."""
    lib = exports[law, precision]
    objects = compile_export(lib, tmp_path / "o", shared=False, extra_flags=["-O2", "-ffreestanding"])
    nm = shutil.which("nm")
    if nm is None:
        pytest.skip("no nm")
    undefined = set()
    for o in objects.glob("*.o"):
        lines = subprocess.run([nm, "-u", str(o)], capture_output=True, text=True, check=True).stdout.split()
        undefined |= {w for w in lines if w != "U"}
    assert undefined and all(s.startswith(lib.prefix + "_") for s in undefined), undefined


@pytest.mark.parametrize("law", LAWS)
def test_compiles_with_clang(exports, tmp_path, law):
    """clang (on the PATH, or zig's from the test extra) at the same strict flags, freestanding, both precisions."""
    from fsmctl.export import strict_flags

    clang = _clang()
    if clang is None:
        pytest.skip("no clang (install the test extra: ziglang)")
    for precision in ("float64", "float32"):
        lib = exports[law, precision]
        for source in lib.sources:
            cmd = [*clang, *strict_flags(precision), "-O2", "-ffreestanding", "-c", str(source)]
            done = subprocess.run([*cmd, "-o", str(tmp_path / f"{precision}-{source.stem}.o")], capture_output=True,
                                  text=True)  # fmt: skip
            assert done.returncode == 0, done.stderr


def test_export_is_byte_reproducible(tmp_path):
    a = write_c_library("fsm", tmp_path / "a", control_period=0.01)
    b = write_c_library("fsm", tmp_path / "b", control_period=0.01)
    for name in a.manifest["sha256"]:
        assert (a.folder / name).read_bytes() == (b.folder / name).read_bytes(), name
    assert a.manifest["sha256"] == b.manifest["sha256"]
    assert read_c_library(a.folder).manifest == a.manifest

    def refuse(token):
        raise ValueError(f"not strict JSON: {token}")

    strict = json.loads((a.folder / "manifest.json").read_text(), parse_constant=refuse)  # no Infinity / NaN token
    assert strict == a.manifest and strict["torque_limit"] == "inf"  # the default: no limit


@pytest.fixture(scope="module")
def short_paper():
    return fsmctl.paper_scenario("1").replace(simulation={"t_final": 3.0})


@pytest.mark.parametrize("law", LAWS)
def test_software_in_the_loop_is_bit_identical_in_float64(exports, short_paper, law):
    """The exported object code flies every agent of the paper's Case 1 at 100 Hz: every recorded array equals the
    engine's own law bit for bit, and the library's own law state equals the engine's at every instant."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        check = verify_export(exports[law, "float64"], short_paper)
    assert check.bit_identical, check.differing_arrays
    assert check.z_mismatches == 0 and check.files_match_manifest and check.passed
    assert check.in_the_loop.u.any()  # the controller did command torques


def test_software_in_the_loop_float32_is_close_and_reported(exports, short_paper):
    """PD in single precision: torques within 1e-3 N m of double (measured ~6e-6 N m: a relative 1e-6 of the
    2 N m limit; single precision's 6e-8 times the gains' growth), not bit-identical, stated in the report."""
    check = verify_export(exports["pid", "float32"], short_paper)
    assert 0 < check.max_torque_error < 1e-3
    assert not check.bit_identical
    text = "\n".join(check.report_lines())
    assert "float32" in text and "largest torque difference" in text and "steady AAEM" in text


def test_a_planted_change_fails_the_check(exports, short_paper, tmp_path):
    """One constant of the exported law changed by one ulp: the flight is no longer bit-identical, and the
    manifest no longer matches."""
    src = exports["fsm", "float64"].folder
    folder = tmp_path / "planted"
    shutil.copytree(src, folder)
    law_c = folder / "fsm_law.c"
    text = law_c.read_text()
    start = text.index("void fsm_law_control(")  # the torque's function: its first constant 0.5
    at = text.index(" = 0.5;", start)
    law_c.write_text(text[:at] + f" = {math.nextafter(0.5, 1.0)!r};" + text[at + len(" = 0.5;") :])
    check = verify_export(folder, short_paper)
    assert not check.bit_identical and not check.passed and not check.files_match_manifest
    assert "NOT bit-identical" in "\n".join(check.report_lines())


HARNESS = r"""
#include <stdio.h>
#include "pid.h"

int main(void) {
  pid_controller c;
  pid_config config;
  pid_input in = {0.0, {0.1, -0.2, 0.05}, {0.01, 0.0, -0.02}, {0, 0, 0}, {0, 0, 0}, {0, 0, 0}};
  pid_real b[PID_N_BROADCAST], nb_b[PID_N_BROADCAST] = {0.05, 0.0, 0.0}, k_own = 1.0, k_sender = 0.5;
  pid_neighbours nb = {1, nb_b, &k_own, &k_sender};
  pid_command cmd;
  pid_default_config(&config);
  int status = pid_init(&c, &config);
  printf("%d %s\n", status, pid_error_text(&c)); /* J0 = 0: refused */
  config.J0[0] = 20; config.J0[4] = 20; config.J0[8] = 20;
  config.parameters.K = -1.0;
  status = pid_init(&c, &config);
  printf("%d %s\n", status, pid_error_text(&c));
  pid_default_config(&config);
  config.J0[0] = 20; config.J0[4] = 20; config.J0[8] = 20;
  config.torque_limit = 2.0;
  printf("%d\n", pid_init(&c, &config));
  printf("%d\n", pid_step(&c, &nb, &cmd)); /* before broadcast */
  status = pid_broadcast(&c, &in, b);
  printf("%d %.17g %.17g %.17g\n", status, b[0], b[1], b[2]);
  status = pid_step(&c, &nb, &cmd);
  printf("%d %.17g %.17g %.17g\n", status, cmd.torque[0], cmd.torque[1], cmd.torque[2]);
  printf("%.17g %.17g\n", cmd.z[0], cmd.z_dot[0]);
  printf("%d\n", pid_step(&c, &nb, &cmd)); /* a second step needs a new broadcast */
  in.omega[1] = 0.0 / 0.0;
  status = pid_broadcast(&c, &in, b);
  printf("%d %s\n", status, pid_error_text(&c));
  return 0;
}
"""


def test_the_c_api_checks_its_inputs_and_computes_the_law(tmp_path):
    """Through a C program: init refuses J0 = 0 and a parameter outside its declared range (naming it), step needs
    broadcast first, a NaN input is refused; the torque equals the law's CasADi function evaluated in Python."""
    lib = write_c_library("pid", tmp_path / "pid", control_period=0.01, error_model="paper")
    harness = tmp_path / "harness.c"
    harness.write_text(HARNESS)
    objects = compile_export(lib, tmp_path / "o", shared=False, extra_sources=[harness], extra_flags=["-O2"])
    exe = tmp_path / "harness"
    subprocess.run([c_compiler(), *map(str, objects.glob("*.o")), "-o", str(exe)], check=True)
    lines = subprocess.run([str(exe)], capture_output=True, text=True, check=True).stdout.splitlines()
    assert lines[0].startswith("2 J0: must be")
    assert lines[1] == "1 K: must be 0 < x" or lines[1].startswith("1 K: must be")
    assert lines[2] == "0" and lines[3] == "5" and lines[7] == "5"
    assert lines[8].startswith("3 an input is not finite")  # the error text names what failed
    code = lib.law
    local, control = code.casadi("law_local_paper"), code.casadi("law_control_paper")
    params = [p.default[0] for p in code.parameters]
    konst = code.casadi("law_constants")(params) if code.n_constants else []
    args = [0.0, [0.1, -0.2, 0.05], [0.01, 0.0, -0.02], [0, 0, 0], [0, 0, 0], [0, 0, 0], [0, 0, 0],
            np.diag([20.0, 20.0, 20.0]), params, konst]  # fmt: skip
    b, cache = local(*args)
    assert [float(v) for v in lines[4].split()[1:]] == pytest.approx(np.asarray(b).ravel().tolist(), abs=0, rel=0)
    u, _, z_dot = control(*args, cache, 1.0, [0.025, 0.0, 0.0], 0.5, 2.0)
    got = [float(v) for v in lines[5].split()[1:]]
    assert got == np.asarray(u).ravel().tolist()
    # the law state: z_dot held over one control period of 0.01 s (one substep), z(0) = 0
    assert float(lines[6].split()[1]) == float(np.asarray(z_dot)[0, 0])
    assert float(lines[6].split()[0]) == pytest.approx(0.01 * float(np.asarray(z_dot)[0, 0]), rel=1e-15)


def test_an_operation_without_a_rule_is_refused():
    import casadi as ca

    x = ca.SX.sym("x")
    with pytest.raises(UnsupportedExportInstructionError, match="OP_SIN"):
        c99_function("f", ca.Function("f", [x], [ca.sin(x)]))


def test_bad_options_are_refused(tmp_path):
    with pytest.raises(ExportError, match="precision"):
        write_c_library("fsm", tmp_path / "a", control_period=0.01, precision="float16")
    with pytest.raises(ExportError, match="prefix"):
        write_c_library("fsm", tmp_path / "a", control_period=0.01, prefix="1bad")
    with pytest.raises(ExportError, match="control period"):
        write_c_library("fsm", tmp_path / "a", control_period=0.0)
    with pytest.raises(ExportError, match="not a folder written"):
        read_c_library(tmp_path)


# ----------------------------------------------------------------------------- the elementary functions


@pytest.fixture(scope="module")
def math_lib(tmp_path_factory):
    lib = write_c_library("fsm_event", tmp_path_factory.mktemp("m") / "m", control_period=0.01)  # pow, sqrt, exp
    so = compile_export(lib, tmp_path_factory.mktemp("so") / "libm_export.so", extra_flags=["-O2"])
    dll = ctypes.CDLL(str(so))
    for name, n in (("pow", 2), ("sqrt", 1), ("exp", 1)):
        f = getattr(dll, f"fsm_event_math_{name}")
        f.restype, f.argtypes = ctypes.c_double, [ctypes.c_double] * n
    return dll


@pytest.fixture(scope="module")
def engine():
    compiled = compiled_library()
    if compiled is None:
        pytest.skip("no compiled engine")
    dll = ctypes.CDLL(str(compiled.path))
    dll.fsmctl_pow.restype, dll.fsmctl_pow.argtypes = ctypes.c_double, [ctypes.c_double, ctypes.c_double]
    return dll


@settings(max_examples=300, deadline=None)
@given(x=st.floats(min_value=1e-300, max_value=1e300), y=st.floats(min_value=-15.9, max_value=15.9))
def test_pow_is_the_engines_on_its_fast_path(math_lib, engine, x, y):
    r = engine.fsmctl_pow(x, y)
    if 2.3e-308 < abs(r) < 1e307:  # the result normal: the fast path of both
        assert math_lib.fsm_event_math_pow(x, y) == r


@pytest.mark.parametrize(
    "x, y",
    [(0.0, 0.7), (-0.0, 3.0), (-0.0, -3.0), (0.0, -2.0), (-2.0, 3.0), (-2.0, 0.5), (1.0, math.nan), (math.nan, 0.0),
     (math.inf, -2.0), (-math.inf, 3.0), (-math.inf, -3.0), (0.5, math.inf), (2.0, -math.inf), (-1.0, math.inf),
     (2.0, 1100.0), (2.0, -1080.0), (1e-310, 0.5), (0.9, 20.0), (3.0, 2.0), (0.3, 1.0)],
)  # fmt: skip
def test_pow_special_cases_follow_c99_annex_f(math_lib, x, y):
    """NumPy's ``power`` is the C library's (C99 Annex F): the same value and sign; off the fast path within 1 ulp."""
    got = math_lib.fsm_event_math_pow(x, y)
    with np.errstate(all="ignore"):
        want = float(np.power(np.float64(x), np.float64(y)))
    if math.isnan(want):
        assert math.isnan(got)
    elif want == 0 or math.isinf(want):
        assert got == want and math.copysign(1, got) == math.copysign(1, want)
    else:
        assert abs(got - want) <= math.ulp(want)


@settings(max_examples=500, deadline=None)
@given(x=st.floats(min_value=0.0, allow_infinity=True, allow_nan=False))
def test_sqrt_is_correctly_rounded(math_lib, x):
    assert math_lib.fsm_event_math_sqrt(x) == math.sqrt(x)


def test_sqrt_and_exp_special_values(math_lib):
    assert math.isnan(math_lib.fsm_event_math_sqrt(-1.0))
    assert math.copysign(1, math_lib.fsm_event_math_sqrt(-0.0)) == -1
    assert math_lib.fsm_event_math_exp(-1000.0) == 0.0 and math_lib.fsm_event_math_exp(1000.0) == math.inf
    rng = np.random.default_rng(7)
    for x in rng.uniform(-700, 700, 2000):
        assert abs(math_lib.fsm_event_math_exp(x) - math.exp(x)) <= math.ulp(math.exp(x))


def test_cli_export_and_verify(tmp_path, capsys):
    from fsmctl.cli.main import main

    rc = main(["export", "--law", "pid", "--out", str(tmp_path / "pid"), "--verify", "--scenario", "paper",
               "--set", "torque_limit=50"])  # fmt: skip
    out = capsys.readouterr().out
    assert rc == 0 and "bit-identical to the engine's own law" in out and (tmp_path / "pid" / "pid.h").is_file()
    assert main(["export", "--law", "pid", "--control-period", "-1"]) == 2
    assert main(["export", "--target", "aem"]) == 2
    with pytest.raises(BuildError):  # a library that does not compile is reported, not flown
        lib = write_c_library("pid", tmp_path / "broken", control_period=0.01)
        (lib.folder / "pid_law.c").write_text("this is not C")
        compile_export(lib, tmp_path / "b.so")


def test_cli_export_aem_round_trip(tmp_path, capsys):
    """``fsmctl export --target aem`` on a result file: one AEM per agent and the reference, read back to the run's
    attitudes (17 significant digits: within 1e-13)."""
    from fsmctl.cli.main import main
    from fsmctl.export import read_aem
    from fsmctl.simulation import load_result

    assert main(["simulate", "--case", "1", "--t-final", "0.2", "--out", str(tmp_path / "run"), "--no-figures"]) == 0
    capsys.readouterr()
    nc = tmp_path / "run" / "paper_case_1.nc"
    assert main(["export", "--target", "aem", "--result", str(nc), "--out", str(tmp_path / "aem")]) == 0
    assert "7 CCSDS AEM files" in capsys.readouterr().out
    back = read_aem(tmp_path / "aem" / "paper-case-1-agent-3.aem")
    result = load_result(nc)
    np.testing.assert_allclose(back.sigma, np.asarray(result["sigma"])[:, 2, :], atol=1e-13)
    assert back.provenance["scenario_toml"] and back.ref_frame_b == "SC_BODY_1"
    assert read_aem(tmp_path / "aem" / "paper-case-1-reference.aem").ref_frame_b == "REFERENCE"
    for path in (tmp_path / "aem").iterdir():  # the NDM/KVN line limit: 254 characters
        assert max(len(line) for line in path.read_text().splitlines()) <= 254, path.name
    assert main(["export", "--target", "aem", "--result", str(nc), "--law", "pid"]) == 2


def test_cli_export_fmu_with_plant(tmp_path, capsys):
    """``fsmctl export --target fmu --with-plant``: both FMUs pass FMPy's validation and fly together (the scenario's
    first spacecraft under PD, its torque within the limit set in the importing tool; the match with the engine, bit
    for bit, is tests/test_export_fmu.py's)."""
    fmpy_validation = pytest.importorskip("fmpy.validation")
    from fsmctl.cli.main import main
    from fsmctl.export import cosimulate

    out = tmp_path / "fmu"
    rc = main(["export", "--law", "pid", "--target", "fmu", "--with-plant", "--neighbours", "2", "--out", str(out)])
    assert rc == 0 and "plant.fmu" in capsys.readouterr().out
    for fmu in ("pid_controller.fmu", "plant.fmu"):
        assert fmpy_validation.validate_fmu(str(out / fmu)) == [], fmu
    run = cosimulate(out / "plant.fmu", out / "pid_controller.fmu", t_final=2.0, step=0.01,
                     controller_parameters={"J0": np.diag([100.0, 150.0, 200.0]), "torque_limit": 2.0})  # fmt: skip
    assert np.all(np.isfinite(run.sigma)) and np.abs(run.torque).max() == 2.0  # saturated, as Case 1 starts
    assert main(["export", "--law", "pid", "--with-plant"]) == 2  # target c takes no plant


def test_set_bakes_the_exported_defaults(tmp_path, capsys):
    """``--set`` values become the export's defaults (C and FMU), checked against the law's declared ranges first;
    without ``--set`` the declared defaults stay."""
    from fsmctl.cli.main import main

    assert main(["export", "--law", "fsm", "--out", str(tmp_path / "c"), "--set", "alpha=0.6",
                 "--set", "torque_limit=2"]) == 0  # fmt: skip
    text = (tmp_path / "c" / "fsm_law.c").read_text()
    assert "p->alpha = 0.6;" in text and "config->torque_limit = 2.0;" in text
    assert read_c_library(tmp_path / "c").manifest["defaults_set"] == {"alpha": [0.6]}
    assert main(["export", "--law", "fsm", "--out", str(tmp_path / "d")]) == 0
    assert "p->alpha = 0.7;" in (tmp_path / "d" / "fsm_law.c").read_text()  # the declared default
    capsys.readouterr()
    assert main(["export", "--law", "fsm", "--target", "fmu", "--out", str(tmp_path / "f"), "--set", "alpha=1.5"]) == 2
    assert "alpha: must be < 1" in capsys.readouterr().err
    assert not (tmp_path / "f").exists()


def test_cli_export_refuses_before_writing(tmp_path, capsys):
    """A control period the scenario cannot fly is refused (naming --control-period) before anything is written;
    --out refuses a folder that holds other files; an option parameter given as text to cosimulate is named."""
    from fsmctl.cli.main import main

    out = tmp_path / "bad"
    assert main(["export", "--law", "fsm", "--control-period", "0.0015", "--verify", "--out", str(out)]) == 2
    assert "--control-period 0.0015 s" in capsys.readouterr().err and not out.exists()
    foreign = tmp_path / "mine"
    foreign.mkdir()
    (foreign / "notes.txt").write_text("mine")
    assert main(["export", "--law", "fsm", "--out", str(foreign)]) == 2
    assert "neither empty nor an earlier export" in capsys.readouterr().err
    assert sorted(p.name for p in foreign.iterdir()) == ["notes.txt"]
