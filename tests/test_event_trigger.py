"""Event-triggered communication (issue 28): ``LawBuilder.trigger``, the engine's rule against the NumPy oracle, the
message counts, the Zeno guard and the built-in ``fsm_event``.

The formation test flies ``tests/data/laws/pd_event.py`` and its independent transcription
(``oracle_numpy.event_triggered_pd_formation``); the link tests fly the clock probe ``echo_event`` (a message is sent
when the clock advanced by more than ``gap``), whose recorded command shows which message each link holds
(``oracle_numpy.event_triggered_clock_links``).
"""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import sympy as sp
from formations import single_spacecraft
from oracle_numpy import event_triggered_clock_links, event_triggered_pd_formation

import fsmctl
from fsmctl.model.generated_code import default_law_dir, law_defines
from fsmctl.model.problem import pack
from fsmctl.model.scenario import ScenarioError, scenario_from_dict
from fsmctl.policy import ZENO_CONSECUTIVE_CHECKS
from fsmctl.simulation import ZenoError, load_result, periodic_messages
from fsmctl.symbolic.law import LawBuilder, LawDefinitionError

LAWS = Path(__file__).parent / "data" / "laws"
PD_EVENT = str(LAWS / "pd_event.py")
ECHO_EVENT = str(LAWS / "echo_event.py")
ECHO = str(LAWS / "echo_time.py")
GAIN = 1e-6

J = [
    [[100.0, 1.0, 2.0], [1.0, 150.0, 1.0], [2.0, 1.0, 200.0]],
    [[120.0, 1.5, 1.0], [1.5, 160.0, 1.0], [1.0, 1.0, 190.0]],
    [[80.0, 0.5, 2.0], [0.5, 180.0, 0.0], [2.0, 0.0, 180.0]],
]
SIGMA0 = [[0.3, 0.2, -0.3], [0.1, 0.3, 0.2], [-0.3, 0.2, -0.1]]
OMEGA0 = [[0.05, -0.02, 0.03], [0.02, -0.06, 0.03], [-0.04, 0.02, -0.01]]


def formation(law=PD_EVENT, t_final=20.0, dt=0.01, period=0.1, **controller):
    """Three spacecraft at rest reference, all-to-all links of weight 1, no disturbance, no torque limit."""
    return scenario_from_dict(
        {
            "name": "event",
            "simulation": {"t_final": t_final, "dt": dt, "output_interval": period or dt, "control_period": period},
            "controller": {"law": law, "torque_limit": math.inf, **controller},
            "reference": {"sigma0": [0.0, 0.0, 0.0], "omega": {"amplitude": [0.0, 0.0, 0.0]}},
            "topology": {"kind": "all-to-all", "k_i": 1.0, "schedule": 1.0},
            "agents": [{"J0": J[i], "sigma0": SIGMA0[i], "omega0": OMEGA0[i]} for i in range(3)],
        }
    )


# ----------------------------------------------------------------------------- the law API


def _builder():
    b = LawBuilder("ev", doc="test")
    c0 = b.parameter("c0", 0.01, minimum=0.0)
    e = b.error_state()
    return b, c0, e


def test_trigger_before_the_broadcast_is_refused():
    b, c0, e = _builder()
    with pytest.raises(LawDefinitionError, match="declare the broadcast before its trigger"):
        b.trigger(e.sigma_e.norm() > c0)
    with pytest.raises(LawDefinitionError, match="declare the broadcast before using the last value sent"):
        _ = b.broadcast_sent


@pytest.mark.parametrize(
    ("condition", "match"),
    [
        (lambda b, c0, e: (e.sigma_e - b.broadcast_sent).norm() >= c0, "strict inequality"),
        (lambda b, c0, e: (e.sigma_e - b.broadcast_sent).norm() - c0, "strict inequality"),
        (lambda b, c0, e: True, "strict inequality"),
        (lambda b, c0, e: b.received.norm() > c0, "must not depend on what the agent receives"),
        (lambda b, c0, e: e.omega_e.norm() > c0, r"not \['omega_e\[0\]'"),
    ],
)
def test_a_bad_trigger_condition_is_refused(condition, match):
    b, c0, e = _builder()
    b.broadcast("sigma_e", e.sigma_e)
    with pytest.raises(LawDefinitionError, match=match):
        b.trigger(condition(b, c0, e))


@pytest.mark.parametrize("period", [0.0, -1.0, math.inf, "1"])
def test_a_bad_trigger_period_is_refused(period):
    b, c0, e = _builder()
    b.broadcast("sigma_e", e.sigma_e)
    with pytest.raises(LawDefinitionError, match="seconds between checks"):
        b.trigger((e.sigma_e - b.broadcast_sent).norm() > c0, period=period)


def test_the_trigger_reads_the_broadcast_through_its_own_symbols():
    """``lhs < rhs`` is ``rhs - lhs > 0``; the declared broadcast expression becomes the ``broadcast`` input."""
    b, c0, e = _builder()
    b.broadcast("sigma_e", e.sigma_e)
    b.trigger(c0 < (e.sigma_e - b.broadcast_sent).norm(), period=0.5)
    b.torque(-e.sigma_e)
    law = b.build()
    assert law.trigger.period == 0.5
    expected = (b.broadcast_now - b.broadcast_sent).norm() - c0
    assert sp.simplify(law.trigger.margin - expected) == 0
    assert law.metadata()["trigger"]["function"] == "law_trigger"


def test_a_law_without_a_trigger_compiles_and_declares_as_before():
    meta = json.loads((default_law_dir() / "law.json").read_text())
    assert "trigger" not in meta
    assert law_defines(default_law_dir()) == ()
    assert not (default_law_dir() / "c" / "law_trigger.c").exists()
    assert fsmctl.model.resolve_law("fsm").trigger is None


# ----------------------------------------------------------------------------- the run settings


def test_an_event_triggered_law_needs_a_control_period():
    with pytest.raises(ScenarioError, match="needs a control period"):
        formation(period=0.0)


def test_a_declared_check_period_must_be_a_multiple_of_the_control_period(tmp_path):
    script = Path(PD_EVENT).read_text().replace('doc="test trigger")', 'doc="test trigger", period=0.3)')
    path = tmp_path / "pd_event_03.py"
    path.write_text(script)
    with pytest.raises(ScenarioError, match=r"0\.3 s, which is not a multiple of simulation\.control_period = 0\.2 s"):
        formation(law=str(path), period=0.2)
    s = formation(law=str(path), t_final=6.0, c0=0.0, c1=0.0)  # a threshold of 0: a message at every check
    assert pack(s).trigger_every == 3
    r = fsmctl.simulate(s)
    checks = np.arange(r.time.size) % 3 == 0
    np.testing.assert_array_equal(r.events_per_output[~checks], 0)
    np.testing.assert_array_equal(r.events_per_output[checks], 1)


# ----------------------------------------------------------------------------- engine against the oracle


def test_the_engine_flies_the_oracle_transcription_of_the_trigger():
    """Three spacecraft, 10 Hz checks: the trajectories agree to 1e-12 and every message (which agent, which
    instant, which link) is the oracle's."""
    s = formation()
    r = fsmctl.simulate(s)
    links = s.topology.links
    o = event_triggered_pd_formation(
        J, SIGMA0, OMEGA0, [lk.sender for lk in links], [lk.receiver for lk in links], [1.0] * len(links),
        K=20.0, P=60.0, c0=0.002, c1=0.02, lam=0.2, dt=0.01, hold=10, n_steps=2000,
    )  # fmt: skip
    np.testing.assert_allclose(r.sigma, o["sigma"], rtol=0, atol=1e-12)
    np.testing.assert_allclose(r.omega, o["omega"], rtol=0, atol=1e-12)
    np.testing.assert_array_equal(r.events_per_output, o["sent"].astype(int))
    np.testing.assert_array_equal(r.messages_sent, o["sent"].sum(axis=0))
    np.testing.assert_array_equal(r.messages_per_link, o["delivered"])
    assert 3 < r.messages_sent.min() and r.messages_sent.max() < 100  # events, not periodic (201 instants)
    gaps = [np.diff(r.time[o["sent"][:, i]]) for i in range(3)]
    np.testing.assert_allclose(r.min_inter_event_s, [g.min() for g in gaps], rtol=1e-12)
    np.testing.assert_allclose(r.mean_inter_event_s, [g.mean() for g in gaps], rtol=1e-12)


def test_neighbours_hold_the_last_value_sent():
    """With the clock probe over ideal links the receivers hold the sender's clock of its last message."""
    s = single_spacecraft(
        law=ECHO_EVENT, n_agents=2, topology={"kind": "all-to-all", "k_i": 1.0, "schedule": 1.0}, t_final=5.0, dt=0.01
    )
    r = fsmctl.simulate(s)
    held, sent, delivered = event_triggered_clock_links(
        r.time, [lk.sender for lk in s.topology.links], 0.25, [0, 0], np.zeros((r.time.size, 2), bool)
    )
    order = [next(e for e, lk in enumerate(s.topology.links) if lk.receiver == i) for i in range(2)]
    np.testing.assert_allclose(r.u_unsaturated[:, :, 0] / GAIN, held[:, order], rtol=0, atol=1e-12)
    np.testing.assert_array_equal(r.messages_per_link, delivered)
    np.testing.assert_array_equal(r.messages_sent, sent.sum(axis=0))
    np.testing.assert_array_equal(sent[:8, 0], [1, 0, 0, 1, 0, 0, 1, 0])  # 0.3 s between messages for gap 0.25 s


@pytest.mark.parametrize(("delay", "loss"), [(0.2, 0.0), (0.0, 0.3), (0.3, 0.2)])
def test_imperfect_links_deliver_only_messages(delay, loss):
    """A delayed, lossy link delivers the message of instant q - d at instant q unless that packet is lost; the
    losses drawn for instants without a message change nothing."""
    s = single_spacecraft(
        law=ECHO_EVENT, n_agents=2, topology={"kind": "all-to-all", "k_i": 1.0, "schedule": 1.0}, t_final=30.0,
        dt=0.01, links={"delay": delay, "loss_probability": loss},
    )  # fmt: skip
    hw = pack(s).hardware
    r = fsmctl.simulate(s)
    held, sent, delivered = event_triggered_clock_links(
        r.time, [lk.sender for lk in s.topology.links], 0.25, hw.link_delay, hw.link_lost.astype(bool)
    )
    # agent i receives on the link whose receiver is i (one each)
    order = [next(e for e, lk in enumerate(s.topology.links) if lk.receiver == i) for i in range(2)]
    np.testing.assert_allclose(r.u_unsaturated[:, :, 0] / GAIN, held[:, order], rtol=0, atol=1e-12)
    np.testing.assert_array_equal(r.messages_per_link, delivered)
    np.testing.assert_array_equal(r.messages_sent, sent.sum(axis=0))
    assert delivered.sum() < sent.sum() or loss == 0


def test_a_trigger_that_always_fires_is_periodic_broadcasting():
    """Sending at every check flies the periodic probe bit for bit, and the loop's counts are periodic
    broadcasting's closed form, over delayed and lossy links too."""
    links = {"delay": 0.2, "loss_probability": 0.3}
    kw = {"n_agents": 2, "topology": {"kind": "all-to-all", "k_i": 1.0, "schedule": 1.0}, "t_final": 5.0, "dt": 0.01}
    event = single_spacecraft(law=ECHO_EVENT, law_parameters={"gap": -1.0}, links=links, **kw)
    periodic = single_spacecraft(law=ECHO, links=links, **kw)
    a, b = fsmctl.simulate(event), fsmctl.simulate(periodic)
    np.testing.assert_array_equal(a.u_unsaturated, b.u_unsaturated)
    assert a.event_triggered and not b.event_triggered
    for name in ("messages_sent", "messages_per_link", "events_per_output"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name), err_msg=name)
    for name in ("min_inter_event_s", "mean_inter_event_s"):  # the loop's differences of instants t0 + k dt
        np.testing.assert_allclose(getattr(a, name), getattr(b, name), rtol=1e-12, err_msg=name)
    hw = pack(periodic).hardware
    closed = periodic_messages(
        n_agents=2, rows=b.time.size, output_every=10, hold_steps=10, dt=0.01,
        link_senders=[lk.sender for lk in periodic.topology.links], link_delay=hw.link_delay, link_lost=hw.link_lost,
    )  # fmt: skip
    np.testing.assert_array_equal(b.messages_per_link, closed["messages_per_link"])
    assert b.messages_sent.tolist() == [51, 51] and b.min_inter_event_s.tolist() == [0.1, 0.1]


def test_continuous_control_has_no_message_counts():
    r = fsmctl.simulate(formation(law=ECHO, period=0.0, t_final=0.5))
    assert r.messages_sent is None and r.messages_line() is None and "messages_sent" not in r.summary()


# ----------------------------------------------------------------------------- Zeno guard


def test_a_trigger_of_threshold_zero_stops_at_the_zeno_guard():
    """Threshold 0: every check whose broadcast moved sends; after ZENO_CONSECUTIVE_CHECKS of them the run stops with
    one line naming the agent, the time, the inter-event time and what to change."""
    s = formation(t_final=20.0, c0=0.0, c1=0.0)
    t_stop = (ZENO_CONSECUTIVE_CHECKS - 1) * 0.1
    with pytest.raises(ZenoError) as caught:
        fsmctl.simulate(s)
    message = str(caught.value)
    assert "\n" not in message
    assert f"Zeno guard: agent 1 of law pd_event sent at each of {ZENO_CONSECUTIVE_CHECKS} consecutive" in message
    assert f"t = {t_stop:.6g} s" in message and "inter-event time 0.1 s" in message and "c0 > 0" in message
    fsmctl.simulate(s.replace(controller={"c0": 0.002}))  # a positive floor flies the same formation


# ----------------------------------------------------------------------------- results and the command line


@pytest.mark.parametrize("fmt", ["netcdf", "csv"])
def test_message_counts_are_saved_and_loaded(tmp_path, fmt):
    r = fsmctl.simulate(formation(t_final=5.0))
    path = r.save(tmp_path / ("run.nc" if fmt == "netcdf" else "run.csv"))
    ds = load_result(path)
    np.testing.assert_array_equal(ds["messages_sent"].values, r.messages_sent)
    np.testing.assert_array_equal(ds["messages_per_link"].values, r.messages_per_link)
    np.testing.assert_array_equal(ds["events_per_output"].values, r.events_per_output)
    np.testing.assert_array_equal(ds["min_inter_event_s"].values, r.min_inter_event_s)


def test_simulate_prints_the_messages_of_the_builtin_event_law(tmp_path, capsys):
    from fsmctl.cli.main import main

    rc = main(
        ["simulate", "--law", "fsm_event", "--control-period", "0.1", "--t-final", "5", "--no-figures",
         "--out", str(tmp_path / "out")]
    )  # fmt: skip
    out = capsys.readouterr().out
    assert rc == 0
    (line,) = [ln.strip() for ln in out.splitlines() if ln.strip().startswith("messages:")]
    assert "event-triggered" in line and "delivered on 30 links" in line
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())["summary"]
    assert summary["event_triggered"] and summary["messages_sent"] < 6 * 51


def test_the_python_control_plugin_refuses_an_event_triggered_law():
    """Its systems broadcast continuously: flying fsm_event there would silently not be event-triggered."""
    from fsmctl.plugin.iosys import law_controller

    with pytest.raises(ScenarioError, match="fsm_event is event-triggered"):
        law_controller("fsm_event", fsmctl.paper_scenario("1").agents[0].J0_array)


def test_fsmctl_laws_shows_the_trigger(capsys):
    from fsmctl.cli.main import main

    assert main(["laws", "fsm_event"]) == 0
    (line,) = [ln for ln in capsys.readouterr().out.splitlines() if ln.strip().startswith("trigger:")]
    assert "threshold_floor + threshold_initial*exp(-t*threshold_decay)" in line and "every control instant" in line


def test_without_the_compiled_loop_an_event_triggered_law_is_refused(monkeypatch):
    """The CasADi fallback does not model triggers: one line, never a silently periodic run."""
    from fsmctl.errors import EnvironmentProblem
    from fsmctl.simulation import simulator

    monkeypatch.setattr(simulator, "_driver", lambda law=None: None)
    with pytest.raises(EnvironmentProblem, match="pd_event is event-triggered, which runs in the compiled simulator"):
        fsmctl.simulate(formation(t_final=1.0))


def test_derive_says_what_triggers_the_broadcast(tmp_path):
    """``fsmctl derive`` of a law with a trigger states the condition and that it needs a control period."""
    done = subprocess.run(
        [sys.executable, "-m", "fsmctl", "derive", str(LAWS / "pd_event.py"), "--out", str(tmp_path / "pd_event")],
        capture_output=True,
        text=True,
    )
    assert done.returncode == 0, done.stderr
    (line,) = [x for x in done.stdout.splitlines() if x.startswith("trigger: ")]
    assert "sends its broadcast when" in line and "needs a control period" in line
    assert "broadcast_sent" in line  # the condition as declared
