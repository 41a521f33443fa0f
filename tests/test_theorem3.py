"""Theorem 3 (Liang et al. 2012, eqs 34-41): simulated settling times against the closed forms.

Oracles: the closed forms (evaluated in 50-digit arithmetic from the proof check's SymPy
expressions) for the simulated times; an independent quadrature of ``T = int_tau^|x0| dx/|f(x)|``
(SciPy, no CasADi) for the closed forms themselves; the analytic LSM solution.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from scipy.integrate import quad

from fsmctl.studies import theorem3 as t3

TOL = 1e-6


def test_default_grid_has_the_extreme_corners():
    g = t3.default_extreme_grid()
    assert min(g.alpha) < 0.501 and max(g.alpha) > 0.999
    assert min(g.tau) <= 1e-12 and max(abs(x) for x in g.x0) >= 1e4
    assert max(g.c1) / min(g.c2) >= 1e4 and max(g.c2) / min(g.c1) >= 1e4
    assert any(x < 0 for x in g.x0)


def test_fast_grid_against_closed_forms_and_ordering():
    study = t3.scalar_settling_study(t3.fast_grid(), progress=False)
    assert len(study.measurements) == 3 * len(t3.fast_grid().points())
    assert study.max_relative_error <= TOL, study.worst
    # Theorem 3 (eqs 37-41): FSM faster than TSM and LSM, on the simulated times
    assert study.ordering_holds, study.summary()["ordering_violations"]


@pytest.mark.slow
def test_full_extreme_grid_against_closed_forms():
    study = t3.scalar_settling_study(progress=False)
    assert len(study.measurements) == 729
    assert study.max_relative_error <= TOL, study.worst
    assert study.ordering_holds


@pytest.mark.parametrize("mode", t3.MODES)
@pytest.mark.parametrize(
    ("c1", "c2", "alpha", "x0", "tau"),
    [(0.6, 0.8, 0.7, 2.0, 1e-3), (0.05, 30.0, 0.51, -3e3, 1e-10), (40.0, 0.02, 0.995, 0.3, 0.29)],
)
def test_closed_forms_against_independent_quadrature(mode, c1, c2, alpha, x0, tau):
    """eqs 34-36 equal int_tau^|x0| dx / (c1 x + c2 x^alpha) (SciPy quad on a log grid: no CasADi, no SymPy)."""
    a, b = (c1, c2) if mode == "fsm" else ((0.0, c2) if mode == "tsm" else (c1, 0.0))
    # substitute x = e^u: dx/(a x + b x^alpha) = du/(a + b e^((alpha-1) u))
    value, _err = quad(lambda u: 1.0 / (a + b * math.exp((alpha - 1) * u)), math.log(tau), math.log(abs(x0)),
                      epsabs=0, epsrel=1e-13, limit=200)  # fmt: skip
    closed = t3.closed_form_settling_time(mode, x0, tau, c1, c2, alpha)
    assert closed == pytest.approx(value, rel=1e-10)


def test_lsm_against_analytic_solution():
    """x = x0 e^(-c1 t) crosses tau at ln(|x0|/tau)/c1 (computed here with NumPy)."""
    m = t3.measure_settling_time("lsm", 5.0, 1e-7, 0.3, 0.8, 0.7)
    assert m.time_simulated_s == pytest.approx(np.log(5.0 / 1e-7) / 0.3, rel=1e-8)


def test_negative_initial_value_is_symmetric():
    pos = t3.measure_settling_time("tsm", 0.7, 1e-4, 0.6, 0.8, 0.6)
    neg = t3.measure_settling_time("tsm", -0.7, 1e-4, 0.6, 0.8, 0.6)
    assert neg.time_simulated_s == pytest.approx(pos.time_simulated_s, rel=1e-9)


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    mode=st.sampled_from(t3.MODES),
    c1=st.floats(1e-2, 1e2),
    c2=st.floats(1e-2, 1e2),
    alpha=st.floats(0.5001, 0.9999),
    log_tau=st.floats(-12, 0),
    log_ratio=st.floats(0.01, 12),
    sign=st.sampled_from([-1.0, 1.0]),
)
def test_random_parameters_against_closed_forms(mode, c1, c2, alpha, log_tau, log_ratio, sign):
    tau = 10.0**log_tau
    x0 = sign * tau * 10.0**log_ratio
    m = t3.measure_settling_time(mode, x0, tau, c1, c2, alpha)
    assert m.relative_error <= TOL, m


@settings(max_examples=15, deadline=None)
@given(
    c1=st.floats(1e-2, 1e2),
    c2=st.floats(1e-2, 1e2),
    alpha=st.floats(0.5001, 0.9999),
    log_tau=st.floats(-9, -1),
    log_ratio=st.floats(0.05, 8),
)
def test_ordering_for_x0_above_tau(c1, c2, alpha, log_tau, log_ratio):
    """|x0| > tau > 0 => T_fsm < T_tsm and T_fsm < T_lsm (eqs 37-41), simulated and closed form."""
    tau = 10.0**log_tau
    x0 = tau * 10.0**log_ratio
    sim = {m: t3.measure_settling_time(m, x0, tau, c1, c2, alpha).time_simulated_s for m in t3.MODES}
    closed = {m: t3.closed_form_settling_time(m, x0, tau, c1, c2, alpha) for m in t3.MODES}
    assert closed["fsm"] < closed["tsm"] and closed["fsm"] < closed["lsm"]
    assert sim["fsm"] < sim["tsm"] and sim["fsm"] < sim["lsm"]


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"alpha": 0.5}, "0.5 < alpha < 1"),
        ({"alpha": 1.0}, "0.5 < alpha < 1"),
        ({"alpha": 1.3}, "0.5 < alpha < 1"),
        ({"tau": 0.0}, "tau must be > 0"),
        ({"tau": -1e-3}, "tau must be > 0"),
        ({"x0": 1e-3}, "|x0| must exceed tau"),
        ({"x0": -5e-4}, "|x0| must exceed tau"),
        ({"c1": 0.0}, "c1 must be > 0"),
        ({"x0": float("nan")}, "finite"),
        ({"mode": "smc"}, "mode must be one of"),
    ],
)
def test_bad_input_gives_a_clear_error(kwargs, message):
    args = {"mode": "fsm", "x0": 1.0, "tau": 1e-3, "c1": 0.6, "c2": 0.8, "alpha": 0.7, **kwargs}
    for fn in (t3.measure_settling_time, t3.closed_form_settling_time):
        with pytest.raises(t3.SettlingTimeInputError, match=message.replace("|", r"\|")) as info:
            fn(**args)
        assert "\n" not in str(info.value)


def test_tsm_does_not_need_c1_and_lsm_does_not_need_c2():
    assert t3.measure_settling_time("tsm", 1.0, 1e-3, 0.0, 0.8, 0.7).relative_error <= TOL
    assert t3.measure_settling_time("lsm", 1.0, 1e-3, 0.6, 0.0, 0.7).relative_error <= TOL


def test_closed_form_latex_comes_from_sympy():
    assert r"\log" in t3.closed_form_latex("fsm") and r"\log" in t3.closed_form_latex("lsm")
    assert r"\log" not in t3.closed_form_latex("tsm")


def test_figure_and_csv(tmp_path):
    fig = t3.plot_settling_time_against_initial_error(x0_values=[0.01, 0.1, 1.0])
    ax = fig.axes[0]
    assert len(ax.lines) == 6 and ax.get_xscale() == "log"
    # the simulated markers lie on the closed-form curves
    for m, (curve, marks) in zip(t3.MODES, zip(ax.lines[::2], ax.lines[1::2], strict=True), strict=True):
        xs, ys = marks.get_data()
        for x, y in zip(xs, ys, strict=True):
            assert y == pytest.approx(t3.closed_form_settling_time(m, x, 1e-3, 0.6, 0.8, 0.7), rel=1e-6)
        assert len(curve.get_xdata()) == 200
    fig.savefig(tmp_path / "t3.png")
    study = t3.scalar_settling_study([(0.6, 0.8, 0.7, 1.0, 1e-3)], progress=False)
    path = t3.write_scalar_study_csv(study, tmp_path / "t3.csv")
    text = path.read_text().splitlines()
    assert text[0].startswith("mode,x0,tau") and len(text) == 4


def test_csv_is_written_atomically(tmp_path, monkeypatch):
    """A write that fails halfway leaves the previous file whole (no truncated CSV), and no temporary file."""
    import csv

    study = t3.scalar_settling_study([(0.6, 0.8, 0.7, 1.0, 1e-3)], progress=False)
    path = t3.write_scalar_study_csv(study, tmp_path / "t3.csv")
    before = path.read_text()

    def fail(self, rows):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(csv.DictWriter, "writerows", fail)
    with pytest.raises(OSError):
        t3.write_scalar_study_csv(study, path)
    assert path.read_text() == before and sorted(p.name for p in tmp_path.iterdir()) == ["t3.csv"]
