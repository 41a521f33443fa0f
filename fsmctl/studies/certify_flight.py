"""A counterexample of ``fsmctl certify`` flown by the simulator: what happens from the point where ``V_dot > 0``.

:func:`fly_counterexample` turns the counterexample's state and uncertainty into a one-agent scenario (the agent of
the certificate, isolated: no links) and flies it with :func:`fsmctl.simulate`; :class:`CounterexampleFlight` holds
the candidate ``V`` and the attitude error along the flight, with a matplotlib figure.

The point becomes initial conditions exactly where the scenario format allows: the true inertia ``J`` (as
``delta_J``), a constant disturbance ``d`` (a sinusoid's offset), the reference at ``sigma_d(0) = 0`` turning with
``omega_d(t) = omega_d + omega_d_dot sin(t)`` (so that both match at ``t = 0``), ``sigma(0) = sigma_e`` and
``omega(0) = omega_e + C(sigma_e) omega_d``.  The law's own states start at their declared initial values (a
scenario cannot set them): the report says so when the counterexample's ``z`` differs.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field

import numpy as np
import sympy as sp

from fsmctl.model.scenario import Scenario, Sinusoid
from fsmctl.model.topology import all_to_all
from fsmctl.proofs.certificate import Certificate
from fsmctl.proofs.certify_problem import candidate_from_record
from fsmctl.proofs.certify_symbolic import state_symbols
from fsmctl.simulation.simulator import simulate

__all__ = ["CounterexampleFlight", "fly_counterexample", "flight_scenario"]

FLIGHT_SECONDS = 20.0
"""default horizon of the flight (s)"""


@dataclass
class CounterexampleFlight:
    """The flight from a counterexample: time, ``V`` and the attitude error angle along it."""

    time: np.ndarray
    V: np.ndarray
    attitude_error_deg: np.ndarray
    notes: list[str] = field(default_factory=list)

    def summary(self) -> str:
        """One line: how ``V`` and the error evolve."""
        k = int(np.argmax(self.V))
        rise = self.V[k] - self.V[0]
        text = (
            f"flown from the counterexample for {self.time[-1]:g} s: V rises by {rise:.3g} to {self.V[k]:.4g} at "
            f"t = {self.time[k]:.3g} s, then {self.V[-1]:.4g} at the end; attitude error "
            f"{self.attitude_error_deg[0]:.3g} deg -> {self.attitude_error_deg[-1]:.3g} deg"
        )
        return text

    def figure(self):
        """A matplotlib figure: ``V`` and the attitude error along the flight."""
        import matplotlib.pyplot as plt

        fig, (a, b) = plt.subplots(2, 1, sharex=True, figsize=(7, 5), constrained_layout=True)
        a.plot(self.time, self.V, color="C3")
        if np.all(self.V > 0):  # V grows by orders of magnitude along a divergent flight
            a.set_yscale("log")
        a.set_ylabel("V along the flight")
        a.set_title("flown from the counterexample (V_dot > 0 at t = 0)")
        b.plot(self.time, self.attitude_error_deg, color="C0")
        b.set_ylabel("attitude error (deg)")
        b.set_xlabel("time (s)")
        return fig


def _point(cert: Certificate | dict) -> tuple[dict, dict]:
    d = cert.as_dict() if isinstance(cert, Certificate) else cert
    c = (d.get("outcome") or {}).get("counterexample")
    if not c:
        raise ValueError("the certificate has no counterexample to fly")
    return d, c["point"]


def _dcm(s: np.ndarray) -> np.ndarray:
    S = np.array([[0, -s[2], s[1]], [s[2], 0, -s[0]], [-s[1], s[0], 0]])
    s2 = float(s @ s)
    return np.eye(3) + (8 * S @ S - 4 * (1 - s2) * S) / (1 + s2) ** 2


def flight_scenario(scenario: Scenario, t_final: float = FLIGHT_SECONDS) -> Scenario:
    """``scenario`` with the horizon of a counterexample's flight, validated like any scenario: call it before a
    search whose counterexample is to be flown, so that a horizon the scenario cannot fly (shorter than its step, not
    a multiple of its output interval) is refused before the search, not after it.

    Raises
    ------
    fsmctl.model.scenario_values.ScenarioError
        ``t_final`` does not fit the scenario's grid.

    Examples
    --------
    >>> from fsmctl import paper_scenario
    >>> from fsmctl.studies.certify_flight import flight_scenario
    >>> flight_scenario(paper_scenario("1"), 5.0).simulation.t_final
    5.0
    """
    return scenario.replace(simulation={"t_final": float(t_final)})


def fly_counterexample(
    certificate: Certificate | dict, scenario: Scenario, *, t_final: float = FLIGHT_SECONDS
) -> CounterexampleFlight:
    """Fly the isolated agent from a certificate's counterexample (see the module docstring).

    Parameters
    ----------
    certificate : Certificate or dict
        A certificate (or its JSON) with a counterexample.
    scenario : Scenario
        The scenario the certificate was made for (its law, the agent's inertia and parameters).
    t_final : float
        Horizon (s).

    Returns
    -------
    CounterexampleFlight

    Raises
    ------
    ValueError
        The certificate has no counterexample.

    Examples
    --------
    >>> from fsmctl import load_scenario
    >>> from fsmctl.proofs.certificate import certify_law
    >>> from fsmctl.proofs.certify import SearchSettings
    >>> from fsmctl.proofs.certify_problem import StateRegion, Uncertainty
    >>> from fsmctl.studies.certify_flight import fly_counterexample

    A deliberately unstable PD law (``docs/examples/pd_unstable.py``, ``EXAMPLES`` that folder):

    >>> sc = load_scenario(EXAMPLES / "my_law.toml").with_law(str(EXAMPLES / "pd_unstable.py"))
    >>> cert = certify_law(EXAMPLES / "pd_unstable.py", scenario=sc, region=StateRegion(0.1, 0.02),
    ...                    uncertainty=Uncertainty(), settings=SearchSettings(max_seconds=10))
    >>> flight = fly_counterexample(cert, sc, t_final=5.0)
    >>> bool(flight.V[-1] > flight.V[0])
    True
    """
    d, point = _point(certificate)
    agent = scenario.agents[d["agent"]["number"] - 1]
    se = np.array([point[f"sigma_e[{k}]"] for k in range(3)])
    we = np.array([point[f"omega_e[{k}]"] for k in range(3)])
    dist = np.array([point[f"d[{k}]"] for k in range(3)])
    wd = np.array([point[f"omega_d[{k}]"] for k in range(3)])
    wdd = np.array([point[f"omega_d_dot[{k}]"] for k in range(3)])
    J0 = agent.J0_array
    theta = [point[n] for n in d["inputs"] if n.startswith("theta")]
    if d["uncertainty"]["inertia_set"] == "proportional":
        J = (1 + theta[0]) * J0
    else:
        J = J0.copy()
        pairs = [(i, j) for i in range(3) for j in range(i, 3) if J0[i, j] != 0]
        for t, (i, j) in zip(theta, pairs, strict=True):
            J[i, j] = J[j, i] = J0[i, j] * (1 + t)
    notes = []
    z = [point[n] for n in d["inputs"] if n.startswith("z[")]
    if any(z):
        notes.append("the law's own states start at their declared initial values, not at the counterexample's z")
    one_agent = dataclasses.replace(
        agent,
        sigma0=tuple(se.tolist()),
        omega0=tuple((we + _dcm(se) @ wd).tolist()),
        delta_J=tuple(map(tuple, (J - J0).tolist())),
        disturbance=Sinusoid(offset=tuple(dist.tolist())),
    )
    reference = {
        "sigma0": [0.0, 0.0, 0.0],
        "omega": {
            "offset": wd.tolist(),
            "amplitude": wdd.tolist(),
            "frequency": [1.0] * 3,
            "phase": [-math.pi / 2] * 3,
        },
    }
    one = flight_scenario(scenario, t_final).replace(
        agents=[one_agent], topology=all_to_all(1, 0.0, 0.0), reference=reference
    )
    result = simulate(one, progress=False)
    s, w, zs = state_symbols(len(z))
    V = candidate_from_record(d["candidate"], len(z))
    fV = sp.lambdify([*s, *w, *zs], V, "numpy")
    se_t, we_t = result.sigma_e[:, 0, :], result.omega_e[:, 0, :]
    zt = result.z[:, 0, :] if len(z) else np.zeros((se_t.shape[0], 0))
    values = np.asarray(fV(*se_t.T, *we_t.T, *zt.T), dtype=float) * np.ones(se_t.shape[0])
    angle = np.degrees(4 * np.arctan(np.linalg.norm(se_t, axis=1)))
    return CounterexampleFlight(np.asarray(result.time), values, angle, notes)
