"""Exact Jacobians of the plug-in's systems, and where they do not exist.

Every fsmctl system evaluates generated CasADi functions; its linearization (:func:`control.linearize`,
``sys.linearize``) differentiates the same graphs, rebuilt once per system from the serialized ``SX`` functions the
C code was generated from (:func:`fsmctl.model.generated_code.model_sx_function`,
:func:`~fsmctl.model.generated_code.law_sx_function`), by CasADi's automatic differentiation: no finite-difference
step.  An interconnection (:class:`fsmctl.plugin.formation_system.FormationSystem`) composes its subsystems' Jacobians through
its connection maps: linear blocks by their matrices, fsmctl systems exactly, any other nonlinear block by
python-control's finite differences (``eps``).

A graph may not be differentiable at the operating point: a ``sign``, a comparison (an ``if_else``), ``fabs``,
``fmin`` or ``fmax`` whose argument sits (within :data:`KINK_TOLERANCE`) at its switch, and whose switch changes
the outputs or their Jacobian (the two sides are evaluated: a kink inside a branch that is not taken, or whose two
sides agree, is no obstacle).  The linearization then raises :class:`NonDifferentiableError` instead of returning
the number one side (or a finite difference across the switch) would give.

:func:`mrp_linearization` gives the six-state linearization in the MRP and the body rate, for control design, and
:func:`mrp_estimator` the static system that closes such a design around the quaternion plant with
:func:`control.create_statefbk_iosystem`.
"""

from __future__ import annotations

import contextvars
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import casadi as ca
import numpy as np

from fsmctl.errors import InputError

__all__ = [
    "NonDifferentiableError",
    "KINK_TOLERANCE",
]

KINK_TOLERANCE = 1e-9
"""A switch's arguments ``a``, ``b`` are at the switch when ``|a - b| <= KINK_TOLERANCE * max(1, |a|, |b|)``."""


class NonDifferentiableError(InputError):
    """A system is not differentiable at the operating point asked of its linearization.

    Raised by :func:`control.linearize` (``sys.linearize``) of an fsmctl system when a switch of its graph (a
    ``sign``, a comparison, ``fabs``, ``fmin``, ``fmax``) sits at the operating point and changes the outputs or
    their Jacobian, or when a derivative there is infinite: the paper's law at ``s = 0`` without a boundary layer,
    ``|s|`` exactly at the layer's edge.  One line naming the system, the switch and what to do (the law's
    smoothing parameter, or another operating point); an :class:`fsmctl.errors.InputError`.

    Examples
    --------
    >>> import numpy as np, fsmctl
    >>> from fsmctl.plugin import NonDifferentiableError
    >>> paper = fsmctl.paper_scenario("1").replace(controller={"boundary_layer": 0.0})  # sgn(s)
    >>> ctrl = fsmctl.fsm_controller(paper.agents[0].J0_array, paper.controller, [0.005] * 3, name="ctrl1")
    >>> try:
    ...     ctrl.linearize([], np.zeros(15))  # s = 0
    ... except NonDifferentiableError as exc:
    ...     print(exc)
    fsm_controller 'ctrl1': not differentiable at the operating point: sign(a) jumps there (a = 0; a depends on sigma[0], omega[0], sigma_d[0], omega_d[0]) and the outputs' values or slopes differ on its two sides; linearize at another operating point (the law's sgn(s) of the switching term u^D (eq 18) is smoothed by its parameter 'boundary_layer' > 0)
    """


# ----------------------------------------------------------------------------- generated functions in a graph

_SYMBOLIC: contextvars.ContextVar[bool] = contextvars.ContextVar("fsmctl_plugin_symbolic", default=False)
"""True while a derivative graph is built: :class:`_Generated` then calls the ``SX`` graphs."""


@dataclass(frozen=True)
class _Generated:
    """A generated function called in a graph: the compiled one (numbers), or, while :func:`symbolic_graph` builds
    a graph to differentiate, its serialized ``SX`` graph (the same derivation).

    ``law`` is the law's folder for a law's function, None for the model's.  Holds names only (picklable).
    """

    name: str
    law: Any = None

    def __call__(self, *args):
        from fsmctl.model import generated_code as gc

        if _SYMBOLIC.get():
            fn = gc.model_sx_function(self.name) if self.law is None else gc.law_sx_function(self.law, self.name)
        else:
            fn = gc.casadi_function(self.name) if self.law is None else gc.law_casadi_function(self.law, self.name)
        return fn(*args)


def symbolic_graph(build: Callable[..., Any], *args) -> Any:
    """``build(*args)`` with every :class:`_Generated` call going to the ``SX`` graph (for differentiation)."""
    token = _SYMBOLIC.set(True)
    try:
        return build(*args)
    finally:
        _SYMBOLIC.reset(token)


# ----------------------------------------------------------------------------- switches of an SX graph

_VALUE_SWITCHES = {
    ca.OP_SIGN: ("sign(a) jumps", (-1.0, 1.0)),
    ca.OP_LT: ("the comparison a < b flips", (0.0, 1.0)),
    ca.OP_LE: ("the comparison a <= b flips", (0.0, 1.0)),
    ca.OP_EQ: ("the comparison a == b flips", (0.0, 1.0)),
    ca.OP_NE: ("the comparison a != b flips", (0.0, 1.0)),
}
"""Operations whose value jumps where their arguments meet, and the values on the two sides."""

_SLOPE_SWITCHES = {
    ca.OP_FABS: "|a| has a corner",
    ca.OP_FMIN: "fmin(a, b) has a corner",
    ca.OP_FMAX: "fmax(a, b) has a corner",
}
"""Operations whose slope jumps where their arguments meet (continuous values)."""


@dataclass(frozen=True)
class _Switch:
    instruction: int
    op: int
    lhs: Any  # SX
    rhs: Any  # SX


def _replay(fn: ca.Function, z: Any, replace: Mapping[int, Any] | None = None) -> tuple[Any, list[_Switch]]:
    """The output of the one-input ``SX`` function ``fn`` rebuilt on ``z`` instruction by instruction, with the
    results of the instructions in ``replace`` replaced, and every switch of the graph."""
    work: dict[int, Any] = {}
    nz: list[Any] = [ca.SX(0)] * fn.nnz_out(0)
    switches = []
    for k in range(fn.n_instructions()):
        op, i, o = fn.instruction_id(k), fn.instruction_input(k), fn.instruction_output(k)
        if op == ca.OP_OUTPUT:
            nz[o[1]] = work[i[0]]
            continue
        if op == ca.OP_CONST:
            value = ca.SX(fn.instruction_constant(k))
        elif op == ca.OP_INPUT:
            value = z[i[1]]
        elif len(i) == 1:
            value = ca.SX.unary(op, work[i[0]])
        else:
            value = ca.SX.binary(op, work[i[0]], work[i[1]])
        if op in _VALUE_SWITCHES or op in _SLOPE_SWITCHES:
            args = [work[j] for j in i]
            switches.append(_Switch(k, op, args[0], args[1] if len(args) > 1 else ca.SX(0)))
        if replace and k in replace:
            value = replace[k]
        work[o[0]] = value
    out = ca.densify(ca.SX(fn.sparsity_out(0), ca.vertcat(*nz))) if nz else ca.SX(0, 1)
    return ca.vec(out), switches


_FORWARD = {"allow_reverse": False}
"""Forward-mode derivatives only: in reverse mode the zero adjoint of a branch that is not taken meets an infinite
local derivative there (``|a|^p``, ``p < 1``, at ``a = 0``) and makes NaN; forward mode masks that branch."""


class Kink(Exception):
    """Internal: a switch at the operating point (the system turns it into :class:`NonDifferentiableError`)."""


class Derivatives:
    """The exact Jacobian of a one-input function with respect to some of its input entries, and the check that
    it exists at the point (built once, from the expanded ``SX`` graph)."""

    def __init__(self, fn: ca.Function, wrt: np.ndarray, labels: Sequence[str]):
        n = fn.nnz_in(0)
        self._fn, self._wrt, self._labels = fn, wrt, list(labels)
        z = ca.SX.sym("z", n)
        out, switches = _replay(fn, z)
        zw = ca.vertcat(*[z[int(j)] for j in wrt]) if len(wrt) else ca.SX(0, 1)
        self._z, self._zw = z, zw
        self._jac = ca.Function("jacobian", [z], [ca.jacobian(out, zw, _FORWARD)])
        self._switches = switches
        self._check: ca.Function | None = None
        self._sides: dict[int, ca.Function] = {}
        self._value_fn: ca.Function | None = None
        if switches:
            lhs = ca.vertcat(*[s.lhs for s in switches])
            rhs = ca.vertcat(*[s.rhs for s in switches])
            self._check = ca.Function("switches", [z], [lhs, rhs, ca.jacobian(lhs - rhs, zw, _FORWARD)])

    def __call__(self, z0: np.ndarray) -> np.ndarray:
        """The Jacobian at ``z0`` (rows: outputs, columns: the ``wrt`` entries); :class:`Kink` if there is none."""
        jac = np.array(self._jac(z0), dtype=float).reshape(-1, len(self._wrt))
        if self._check is not None:
            self._switch_at(z0)
        if not np.isfinite(jac).all():
            _, cols = np.nonzero(~np.isfinite(jac))
            raise Kink(
                f"the derivative with respect to {self._labels[cols[0]]} is not finite there (a power |a|^p with "
                "p < 1 at a = 0, or a division by zero)"
            )
        return jac

    def _switch_at(self, z0: np.ndarray) -> None:
        lhs, rhs, grad = (np.array(v, dtype=float) for v in self._check(z0))
        lhs, rhs = lhs.ravel(), rhs.ravel()
        grad = grad.reshape(len(self._switches), len(self._wrt))
        with np.errstate(invalid="ignore"):  # an infinite limit (a wheel without a speed limit) is never reached
            gap = np.abs(lhs - rhs)
            at = np.isfinite(gap) & (gap <= KINK_TOLERANCE * np.maximum(1.0, np.maximum(np.abs(lhs), np.abs(rhs))))
        moving = np.any(grad != 0, axis=1)  # its arguments move with the states/inputs (else it cannot switch)
        candidates = np.nonzero(at & moving)[0]
        if candidates.size == 0:
            return
        v0 = np.array(self._values(z0), dtype=float).ravel()
        for j in candidates:
            s = self._switches[j]
            sides = self._side_function(int(j))  # the switch's result a free variable v, the others as they are
            if s.op in _SLOPE_SWITCHES:
                # the two sides' Jacobians differ by (d out / d v) (grad a - grad b)^T (times 2 for fabs): a corner
                # matters when that difference is not rounding next to the Jacobian itself (|a| times a factor that
                # is itself zero up to rounding, as at an equilibrium with sigma_d != 0, is smooth)
                side = [np.array(m, dtype=float) for m in sides(z0, v0[j])]
                jac, d_out = side[1].reshape(-1, len(self._wrt)), side[2].ravel()
                jump = (2.0 if s.op == ca.OP_FABS else 1.0) * np.outer(d_out, grad[j])
                jumps = not _close(jac, jac + jump)
                what = _SLOPE_SWITCHES[s.op]
            else:
                what, (lo, hi) = _VALUE_SWITCHES[s.op]
                ea = [np.array(m, dtype=float) for m in sides(z0, lo)][:2]
                eb = [np.array(m, dtype=float) for m in sides(z0, hi)][:2]
                jumps = not all(_close(x, y) for x, y in zip(ea, eb, strict=True))
            if jumps:
                on = [self._labels[c] for c in np.nonzero(grad[j])[0]]
                shown = ", ".join(on[:4]) + (", ..." if len(on) > 4 else "")
                unary = s.op in (ca.OP_SIGN, ca.OP_FABS)
                gap = f"a = {lhs[j]:.3g}" if unary else f"a - b = {lhs[j] - rhs[j]:.3g}"
                raise Kink(
                    f"{what} there ({gap}; {'a depends' if unary else 'a, b depend'} on {shown}) and the outputs' "
                    "values or slopes differ on its two sides"
                )

    def _values(self, z0: np.ndarray):
        """The switches' own results at ``z0`` (the nominal side of each)."""
        if self._value_fn is None:
            nodes = ca.vertcat(*[_instruction_value(s) for s in self._switches])
            self._value_fn = ca.Function("switch_values", [self._z], [nodes])
        return self._value_fn(z0)

    def _side_function(self, j: int) -> ca.Function:
        """``(z, v) -> (out, d out / d z_wrt, d out / d v)`` with switch ``j``'s result replaced by ``v``."""
        if j not in self._sides:
            v = ca.SX.sym("v")
            out, _ = _replay(self._fn, self._z, {self._switches[j].instruction: v})
            self._sides[j] = ca.Function(
                "sides", [self._z, v], [out, ca.jacobian(out, self._zw, _FORWARD), ca.jacobian(out, v, _FORWARD)]
            )
        return self._sides[j]


def _instruction_value(s: _Switch) -> Any:
    return ca.SX.unary(s.op, s.lhs) if s.op in (ca.OP_SIGN, ca.OP_FABS) else ca.SX.binary(s.op, s.lhs, s.rhs)


def _close(a: np.ndarray, b: np.ndarray) -> bool:
    scale = max(1.0, float(np.max(np.abs(a), initial=0.0)), float(np.max(np.abs(b), initial=0.0)))
    return bool(np.all(np.abs(a - b) <= 1e-9 * scale))


def derivatives(fn_mx: ca.Function, wrt: np.ndarray, labels: Sequence[str]) -> Derivatives:
    """:class:`Derivatives` of an ``MX`` function of one input whose calls go to ``SX`` functions (expanded)."""
    return Derivatives(fn_mx.expand(), wrt, labels)


# ----------------------------------------------------------------------------- interconnections


def interconnection_jacobians(sys: Any, t: float, x: np.ndarray, u: np.ndarray, eps: float) -> tuple[np.ndarray, ...]:
    """``(A, B, C, D)`` of a :class:`control.InterconnectedSystem` at ``(t, x, u)`` from its subsystems' Jacobians.

    With the parameters python-control last handed the subsystems (``sys._update_params`` first).  Subsystem ``i``
    is linearized at its own state and the inputs the interconnection gives it; with ``Y = C x + D U`` (stacked
    outputs), ``U = M Y + N u`` (``connect_map``, ``input_map``): ``U = (I - M D)^-1 (M C x + N u)``; the outputs
    are ``output_map [Y; U]``.
    """
    import control as ct

    ulist, _ = sys._compute_static_io(t, x, u)
    blocks = {"A": [], "B": [], "C": [], "D": []}
    xi = ui = 0
    for sub in sys.syslist:
        xs, us = x[xi : xi + sub.nstates], ulist[ui : ui + sub.ninputs]
        if isinstance(sub, ct.StateSpace):
            mats = (sub.A, sub.B, sub.C, sub.D)
        elif hasattr(sub, "_jacobians"):
            mats = sub._jacobians(t, xs, us)
        elif isinstance(sub, ct.InterconnectedSystem):
            mats = interconnection_jacobians(sub, t, xs, us, eps)
        else:  # a nonlinear block of the user's: python-control's finite differences, with its current parameters
            lin = ct.NonlinearIOSystem.linearize(sub, xs, us, t=t, params=sub._current_params, eps=eps)
            mats = (lin.A, lin.B, lin.C, lin.D)
        for key, m in zip("ABCD", mats, strict=True):
            blocks[key].append(np.asarray(m, dtype=float).reshape(_shape(key, sub)))
        xi += sub.nstates
        ui += sub.ninputs
    A, B, C, D = (_block_diag(blocks[k]) for k in "ABCD")
    M, N, P = sys.connect_map, sys.input_map, sys.output_map
    ny = M.shape[1]
    loop = np.eye(M.shape[0]) - M @ D
    Ux = np.linalg.solve(loop, M @ C)
    Uu = np.linalg.solve(loop, N)
    Yx, Yu = C + D @ Ux, D @ Uu
    return (
        A + B @ Ux,
        B @ Uu,
        P[:, :ny] @ Yx + P[:, ny:] @ Ux,
        P[:, :ny] @ Yu + P[:, ny:] @ Uu,
    )


def _shape(key: str, sub: Any) -> tuple[int, int]:
    rows = sub.nstates if key in "AB" else sub.noutputs
    cols = sub.nstates if key in "AC" else sub.ninputs
    return rows, cols


def _block_diag(mats: Sequence[np.ndarray]) -> np.ndarray:
    out = np.zeros((sum(m.shape[0] for m in mats), sum(m.shape[1] for m in mats)))
    r = c = 0
    for m in mats:
        out[r : r + m.shape[0], c : c + m.shape[1]] = m
        r += m.shape[0]
        c += m.shape[1]
    return out
