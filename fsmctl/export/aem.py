"""Attitude histories as CCSDS Attitude Ephemeris Messages (AEM, CCSDS 504.0-B-2 "ADM" version 2).

:func:`write_aem` writes one AEM per agent of a :class:`~fsmctl.simulation.result.SimulationResult` (and one
for the reference attitude ``sigma_d``); :func:`read_aem` reads any single-segment quaternion AEM back into an
:class:`AttitudeEphemeris`.  The messages are built, serialized, parsed and validated by the ``ccsds-ndm-py``
library (import name ``ccsds_ndm``, MPL-2.0), in KVN (the default) or XML.

The conventions, stated once here and in every file's comments:

* **quaternion**: AEM version 2 has one order, ``Q1 Q2 Q3 QC``: the vector part, then the scalar part
  (scalar last).  It is the rotation from ``REF_FRAME_A`` (the scenario's inertial frame ``N``, labelled
  :data:`INERTIAL_FRAME` unless told otherwise) to ``REF_FRAME_B`` (the agent's body frame ``B``,
  :data:`BODY_FRAME`): the Euler parameters of ``[BN]``, the direction-cosine matrix that maps a vector's
  components in ``N`` to its components in ``B`` (Schaub & Junkins), the same attitude as fsmctl's MRP
  ``sigma`` (``sigma = q_v / (1 + q_c)``).  The conversion is :func:`fsmctl.model.attitude.quaternion_from_mrp`.
* **sign continuity**: ``q`` and ``-q`` are one attitude.  fsmctl's MRPs switch to the shadow set at
  ``|sigma| = 1`` (180 degrees), where the quaternion of the formula changes sign; :func:`aem_quaternions` keeps
  the first sample's ``QC >= 0`` and then, sample by sample, the sign nearest the previous sample (the one with
  a non-negative dot product), so the written quaternion never jumps and interpolates as the attitude does.
* **rates**: agents are written as ``QUATERNION/ANGVEL``: the angular velocity of ``B`` relative to ``N``
  (fsmctl's ``omega``) in ``B`` components (``ANGVEL_FRAME = REF_FRAME_B``), in deg/s as the standard requires.
  The reference, whose rate a result does not keep, is written as ``QUATERNION``.
* **time**: a scenario has no calendar epoch; ``t = 0`` is :data:`DEFAULT_EPOCH` (``TIME_SYSTEM = UTC``) unless
  told otherwise, recorded in the comment ``time_origin_utc``.  Epochs are written with every decimal digit of
  ``repr(t)`` (at least :data:`MIN_FRACTION_DIGITS`), so :func:`read_aem` gives back ``t`` bit for bit.  Days are
  86400 s (no leap second inside a run: from the default epoch the next one is at the end of 2005).
* **digits**: the library writes each float as its shortest round-trip decimal (up to 17 significant digits),
  so the quaternions and rates read back are the float64 numbers written.
* **provenance**: the header comments hold :func:`fsmctl.simulation.results_io.provenance` (scenario, law,
  versions, command; for a result file, the provenance it recorded) as ``key = <JSON value>`` lines, as the CSV result files do; the scenario TOML follows as
  ``scenario_toml | <line>`` comments.  :attr:`AttitudeEphemeris.provenance` gives them back.

Examples
--------
>>> import tempfile, fsmctl
>>> from fsmctl.export import read_aem, write_aem
>>> r = fsmctl.simulate(fsmctl.paper_scenario("1").replace(simulation={"t_final": 0.1}))
>>> paths = write_aem(r, tempfile.mkdtemp(), agents=[1])
>>> [p.name for p in paths]
['paper-case-1-agent-1.aem', 'paper-case-1-reference.aem']
>>> e = read_aem(paths[0])
>>> e.object_name, e.ref_frame_a, e.ref_frame_b, e.quaternion.shape, bool((e.time == r.time).all())
('paper-case-1-agent-1', 'EME2000', 'SC_BODY_1', (11, 4), True)
>>> bool(abs(e.sigma - r.sigma[:, 0]).max() < 1e-12), e.provenance["law"]
(True, 'fsm')
"""

from __future__ import annotations

import json
import re
import shlex
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from datetime import UTC, date, datetime, timedelta
from decimal import ROUND_FLOOR, Context, Decimal
from pathlib import Path
from typing import TYPE_CHECKING

import ccsds_ndm
import numpy as np
import xarray as xr

from fsmctl.errors import InputError
from fsmctl.model.attitude import mrp_from_quaternion, quaternion_from_mrp
from fsmctl.outputs import write_text
from fsmctl.simulation.results_io import provenance

if TYPE_CHECKING:
    from fsmctl.simulation.result import SimulationResult

__all__ = [
    "AemError",
    "NotAnAemError",
    "UnknownAgentError",
    "EmptyResultError",
    "AttitudeEphemeris",
    "aem_quaternions",
    "mrp_from_aem_quaternions",
    "write_aem",
    "read_aem",
    "DEFAULT_EPOCH",
    "TIME_SYSTEM",
    "INERTIAL_FRAME",
    "BODY_FRAME",
    "REFERENCE_FRAME",
    "COMMENT_WIDTH",
    "FORMATS",
    "MIN_FRACTION_DIGITS",
    "QUATERNION_CONVENTION",
]

# ----------------------------------------------------------------------------- policy constants

DEFAULT_EPOCH = datetime(2000, 1, 1, 12, 0, 0)
"""The UTC calendar date of ``t = 0`` when :func:`write_aem` is given none (J2000.0 noon, written in UTC)."""
TIME_SYSTEM = "UTC"
"""The AEM ``TIME_SYSTEM`` of the epochs :func:`write_aem` writes."""
INERTIAL_FRAME = "EME2000"
"""The default ``REF_FRAME_A``: the label given to the scenario's inertial frame ``N`` (fsmctl's ``N`` is an
abstract inertial frame; pass ``inertial_frame=`` to name the one it stands for)."""
BODY_FRAME = "SC_BODY_1"
"""``REF_FRAME_B`` of an agent's message: its body frame ``B``."""
REFERENCE_FRAME = "REFERENCE"
"""``REF_FRAME_B`` of the reference's message: the reference frame ``D`` of ``sigma_d`` (no SANA frame name stands for
a desired attitude; the comments say what it is)."""
COMMENT_WIDTH = 200
"""Characters of a provenance value or a scenario line per comment line: a longer one continues on the next
(``key += ...``, ``scenario_toml + ...``), so that every KVN line stays under the 254 characters of the NDM/KVN rules."""
FORMATS = {"kvn": ".aem", "xml": ".xml"}
"""The encodings :func:`write_aem` writes, and the file suffix of each (:func:`read_aem` reads both)."""
MIN_FRACTION_DIGITS = 6
"""Fewest decimals of the seconds in a written epoch (more when ``repr(t)`` needs them, never fewer)."""
QUATERNION_CONVENTION = (
    "Q1 Q2 Q3 QC: vector part then scalar part (scalar last), unit; the rotation from REF_FRAME_A to "
    "REF_FRAME_B (Euler parameters of the DCM [BA] that maps components in A to components in B)"
)
"""The quaternion convention of AEM version 2, the only one :func:`write_aem` writes and :func:`read_aem` reads."""

_ORIGIN_KEY = "time_origin_utc"
_TOML_PREFIX = "scenario_toml |"
_TOML_MORE = "scenario_toml +"
_QUATERNION_TYPES = {"QUATERNION": 0, "QUATERNION/ANGVEL": 3}
"""the attitude types read, and the number of rate columns after the quaternion"""
_EPOCH = re.compile(r"^(\d{4})-(?:(\d{2})-(\d{2})|(\d{3}))T(\d{2}):(\d{2}):(\d{2})(\.\d*)?Z?$")
_DATASET_VARIABLES = ("time_s", "sigma", "omega_rad_per_s", "sigma_d")
"""the variables of a result file (:func:`fsmctl.simulation.results_io.load_result`) an AEM is made of"""
_KEY_VALUE = re.compile(r"^([A-Za-z_][A-Za-z0-9_]*) (\+?=) (.*)$")
_DECIMAL = Context(prec=60)

# ----------------------------------------------------------------------------- errors


class AemError(InputError):
    """An AEM cannot be written or read as asked (the message says why, in one line).

    Examples
    --------
    >>> issubclass(AemError, InputError)
    True
    """


class NotAnAemError(AemError):
    """The file is not a CCSDS Attitude Ephemeris Message (not CCSDS at all, another message, unreadable).

    Examples
    --------
    >>> import tempfile, pathlib
    >>> p = pathlib.Path(tempfile.mkdtemp()) / "x.aem"
    >>> _ = p.write_text("hello")
    >>> try:
    ...     read_aem(p)
    ... except NotAnAemError as exc:
    ...     print(str(exc).split(": ", 1)[1])
    not a CCSDS AEM (Could not identify KVN header)
    """


class UnknownAgentError(AemError):
    """An agent number outside ``1..n``.

    Examples
    --------
    >>> issubclass(UnknownAgentError, AemError)
    True
    """


class EmptyResultError(AemError):
    """A result without a single time sample has no attitude history to write.

    Examples
    --------
    >>> issubclass(EmptyResultError, AemError)
    True
    """


# ----------------------------------------------------------------------------- quaternions


def aem_quaternions(sigma) -> np.ndarray:
    """AEM quaternions (``Q1 Q2 Q3 QC``, scalar last) of an MRP history, with a continuous sign.

    Parameters
    ----------
    sigma : array_like, shape (T, 3)
        MRPs of the rotation from ``N`` to ``B`` at successive samples (shadow set or not).

    Returns
    -------
    numpy.ndarray, shape (T, 4)
        Unit quaternions, scalar last; the first has ``QC >= 0`` when ``|sigma[0]| <= 1``, each next one the sign
        that makes its dot product with the previous one non-negative.

    Raises
    ------
    ValueError
        ``sigma`` is not of shape (T, 3).

    Examples
    --------
    >>> import numpy as np
    >>> z = np.tan(np.radians([170.0, 190.0]) / 4)  # about z, through 180 deg
    >>> sigma = np.array([[0, 0, z[0]], [0, 0, -1 / z[1]]])  # the second in the shadow set
    >>> aem_quaternions(sigma).round(4).tolist()
    [[0.0, 0.0, 0.9962, 0.0872], [0.0, 0.0, 0.9962, -0.0872]]
    """
    s = np.asarray(sigma, dtype=float)
    if s.ndim != 2 or s.shape[1] != 3:
        raise ValueError(f"expected MRPs of shape (T, 3), got shape {s.shape}")
    q = np.roll(quaternion_from_mrp(s), -1, axis=1)  # (q0, qv) -> (qv, qc)
    if len(q) > 1:
        dots = np.einsum("ij,ij->i", q[1:], q[:-1])
        q[1:] *= np.cumprod(np.where(dots < 0, -1.0, 1.0))[:, None]
    return q


def mrp_from_aem_quaternions(quaternion) -> np.ndarray:
    """MRPs (shadow set, ``|sigma| <= 1``) of AEM quaternions (``Q1 Q2 Q3 QC``, scalar last).

    Parameters
    ----------
    quaternion : array_like, shape (..., 4)
        Quaternions, scalar last, of any non-zero norm and either sign.

    Returns
    -------
    numpy.ndarray, shape (..., 3)

    Examples
    --------
    >>> import numpy as np
    >>> h = np.sqrt(0.5)
    >>> mrp_from_aem_quaternions([0.0, 0.0, h, h]).round(6).tolist()  # 90 deg about z: tan(22.5 deg)
    [0.0, 0.0, 0.414214]
    """
    q = np.asarray(quaternion, dtype=float)
    return mrp_from_quaternion(np.roll(q, 1, axis=-1))


# ----------------------------------------------------------------------------- epochs


def _utc_naive(epoch: datetime) -> datetime:
    if epoch.tzinfo is not None:
        epoch = epoch.astimezone(UTC).replace(tzinfo=None)
    return epoch


def _epoch_text(origin: datetime, t: float) -> str:
    """The AEM epoch of ``origin + t`` with every decimal of ``repr(t)`` (read back exactly)."""
    total = _DECIMAL.add(Decimal(repr(float(t))), _DECIMAL.divide(Decimal(origin.microsecond), Decimal(10**6)))
    whole = int(total.to_integral_value(rounding=ROUND_FLOOR))
    fraction = format(_DECIMAL.subtract(total, Decimal(whole)), "f").partition(".")[2]
    stamp = (origin.replace(microsecond=0) + timedelta(seconds=whole)).strftime("%Y-%m-%dT%H:%M:%S")
    return f"{stamp}.{fraction.ljust(MIN_FRACTION_DIGITS, '0')}"


def _calendar(text: str) -> tuple[datetime, Decimal]:
    """The whole second and the fraction of an AEM calendar epoch (``YYYY-MM-DDThh:mm:ss[.f]`` or day of year)."""
    m = _EPOCH.match(text.strip())
    if m is None:
        raise AemError(f"epoch {text!r}: not a calendar epoch YYYY-MM-DDThh:mm:ss[.f] or YYYY-DDDThh:mm:ss[.f]")
    year, month, day, doy, hh, mm, ss, fraction = m.groups()
    try:
        d = date(int(year), int(month), int(day)) if doy is None else date(int(year), 1, 1) + timedelta(int(doy) - 1)
        whole = datetime(d.year, d.month, d.day, int(hh), int(mm), int(ss))
    except ValueError as exc:
        raise AemError(f"epoch {text!r}: {exc} (leap seconds are not read)") from None
    return whole, Decimal("0" + (fraction if fraction and fraction != "." else ".0"))


def _seconds_since(origin: datetime, text: str) -> float:
    whole, fraction = _calendar(text)
    delta = whole - origin.replace(microsecond=0)
    seconds = _DECIMAL.add(Decimal(delta.days * 86400 + delta.seconds), fraction)
    return float(_DECIMAL.subtract(seconds, _DECIMAL.divide(Decimal(origin.microsecond), Decimal(10**6))))


# ----------------------------------------------------------------------------- writing


def _slug(text: str) -> str:
    return re.sub(r"[^A-Za-z0-9._-]+", "-", text).strip("-") or "fsmctl"


def _agent_numbers(agents: Iterable[int] | None, n: int) -> list[int]:
    if agents is None:
        return list(range(1, n + 1))
    numbers = list(dict.fromkeys(agents))
    for k in numbers:
        if isinstance(k, bool) or not isinstance(k, (int, np.integer)) or not 1 <= k <= n:
            raise UnknownAgentError(f"agent {k!r}: the result has agents 1..{n}")
    return [int(k) for k in numbers]


@dataclass(frozen=True, eq=False)
class _History:
    """What an AEM needs of a run, from a :class:`SimulationResult` or a result file's dataset."""

    label: str
    time: np.ndarray
    sigma: np.ndarray
    omega: np.ndarray
    sigma_d: np.ndarray
    attrs: dict[str, object]


def _history(result: SimulationResult | xr.Dataset, command) -> _History:
    if isinstance(result, xr.Dataset):
        missing = [v for v in _DATASET_VARIABLES if v not in result.variables]
        if missing or "scenario_label" not in result.attrs:
            what = ", ".join(missing) or "the attribute scenario_label"
            raise AemError(f"the dataset is not an fsmctl result (no {what}): read it with load_result")
        attrs = {k: v for k, v in result.attrs.items() if isinstance(v, (str, int, float, bool))}
        if command is not None:
            attrs["export_command"] = command if isinstance(command, str) else shlex.join(str(c) for c in command)
        time, sigma, omega, sigma_d = (np.asarray(result[v].values, dtype=float) for v in _DATASET_VARIABLES)
        return _History(str(attrs["scenario_label"]), time, sigma, omega, sigma_d, attrs)
    attrs = dict(provenance(result.scenario, command=command))
    arrays = (np.asarray(a, dtype=float) for a in (result.time, result.sigma, result.omega, result.sigma_d))
    return _History(result.scenario.label, *arrays, attrs)


def _chunks(text: str) -> list[str]:
    return [text[i : i + COMMENT_WIDTH] for i in range(0, len(text), COMMENT_WIDTH)] or [""]


def _header_comments(attrs: Mapping[str, object]) -> list[str]:
    toml = str(attrs.get("scenario_toml", ""))
    lines = []
    for key, value in attrs.items():
        if key != "scenario_toml":
            first, *rest = _chunks(json.dumps(value))
            lines += [f"{key} = {first}", *(f"{key} += {c}" for c in rest)]
    for line in toml.splitlines():
        first, *rest = _chunks(line)
        lines += [f"{_TOML_PREFIX} {first}".rstrip(), *(f"{_TOML_MORE} {c}" for c in rest)]
    return lines


def _object_name(fmt: str, **fields) -> str:
    try:
        return fmt.format(**fields)
    except (KeyError, IndexError, ValueError) as exc:
        raise AemError(
            f"object name format {fmt!r}: {exc} (fields: {', '.join('{' + k + '}' for k in fields)})"
        ) from None


def _message(header: ccsds_ndm.AdmHeader, meta: dict, comments: list[str], epochs: list[str], rows) -> ccsds_ndm.Aem:
    metadata = ccsds_ndm.AemMetadata(
        start_time=epochs[0], stop_time=epochs[-1], time_system=TIME_SYSTEM, comment=comments, **meta
    )
    data = ccsds_ndm.AemData.from_numpy(epochs, np.ascontiguousarray(rows), attitude_type=meta["attitude_type"])
    return ccsds_ndm.Aem(header=header, segments=[ccsds_ndm.AemSegment(metadata, data)])


def write_aem(
    result: SimulationResult | xr.Dataset,
    out_dir: str | Path,
    *,
    agents: Iterable[int] | None = None,
    originator: str = "fsmctl",
    object_name_format: str = "{scenario}-agent-{k}",
    reference_name_format: str | None = "{scenario}-reference",
    epoch: datetime = DEFAULT_EPOCH,
    inertial_frame: str = INERTIAL_FRAME,
    format: str = "kvn",
    command: Sequence[str] | str | None = None,
    creation_date: datetime | None = None,
) -> list[Path]:
    """Write a run's attitude histories as CCSDS AEMs: one message (file) per agent, and one for the reference.

    Parameters
    ----------
    result : SimulationResult or xarray.Dataset
        The run (:func:`fsmctl.simulate`), or a result file as read by
        :func:`fsmctl.simulation.results_io.load_result` (its recorded provenance is written as it is, with
        ``export_command``; a float32 file gives the quaternions of its float32 MRPs).
    out_dir : str or Path
        The folder (created when missing); each file is ``<object name><suffix>`` (characters other than
        letters, digits, ``.``, ``_``, ``-`` become ``-``), written atomically.
    agents : iterable of int, optional
        Agent numbers ``1..n`` (as the CSV columns and the topology count them); all agents by default.
    originator : str
        The AEM ``ORIGINATOR``.
    object_name_format : str
        ``OBJECT_NAME`` (and ``OBJECT_ID``) of agent ``k``; fields ``{scenario}`` (the scenario's label with
        ``-`` for spaces, ``paper-case-1``), ``{k}`` (the agent number) and ``{n}`` (the number of agents).
    reference_name_format : str or None
        ``OBJECT_NAME`` of the reference attitude ``sigma_d`` (the frame ``R`` as its own object, a ``QUATERNION``
        message), same fields but ``{k}``; None writes no reference message.
    epoch : datetime.datetime
        The UTC date of ``t = 0`` (a naive datetime is UTC); :data:`DEFAULT_EPOCH` by default.
    inertial_frame : str
        ``REF_FRAME_A``: the name of the frame the scenario's ``N`` stands for.
    format : {"kvn", "xml"}
        The encoding (:data:`FORMATS`).
    command : sequence of str or str, optional
        The command line, recorded in the provenance comments (``command``; ``export_command`` for a dataset).
    creation_date : datetime.datetime, optional
        The header's ``CREATION_DATE`` (UTC); now by default.

    Returns
    -------
    list of Path
        The files, agents first (in the order given), the reference last.

    Raises
    ------
    EmptyResultError
        The result has no time sample.
    UnknownAgentError
        An agent number outside ``1..n``.
    AemError
        A dataset that is not an fsmctl result, an object name format with an unknown field, two objects with one file name, an unknown format.
    EnvironmentProblem
        A file cannot be written.

    Examples
    --------
    >>> import tempfile, fsmctl
    >>> r = fsmctl.simulate(fsmctl.paper_scenario("1").replace(simulation={"t_final": 0.1}))
    >>> paths = write_aem(r, tempfile.mkdtemp(), agents=[2, 3], reference_name_format=None, format="xml")
    >>> [p.name for p in paths]
    ['paper-case-1-agent-2.xml', 'paper-case-1-agent-3.xml']
    >>> read_aem(paths[1]).angular_velocity_frame
    'SC_BODY_1'
    """
    if format not in FORMATS:
        raise AemError(f"format {format!r}: choose one of {', '.join(FORMATS)}")
    run = _history(result, command)
    if run.time.shape[0] == 0 or run.sigma.shape[0] == 0:
        raise EmptyResultError(f"{run.label}: the result has no time sample, so no attitude history")
    n = run.sigma.shape[1]
    numbers = _agent_numbers(agents, n)
    fields = {"scenario": _slug(run.label), "n": n}
    origin = _utc_naive(epoch)
    created = _utc_naive(creation_date or datetime.now(UTC)).strftime("%Y-%m-%dT%H:%M:%S")
    header = ccsds_ndm.AdmHeader(creation_date=created, originator=originator, comment=_header_comments(run.attrs))
    epochs = [_epoch_text(origin, t) for t in run.time]
    common = [
        f"{_ORIGIN_KEY} = {json.dumps(origin.isoformat())}",
        f"quaternion: {QUATERNION_CONVENTION}; sign continuous (nearest the previous sample)",
        f"REF_FRAME_A = {inertial_frame}: the scenario's inertial frame N; time = seconds since {_ORIGIN_KEY}",
    ]
    jobs: list[tuple[str, dict, list[str], np.ndarray]] = []
    for k in numbers:
        name = _object_name(object_name_format, k=k, **fields)
        rows = np.hstack([aem_quaternions(run.sigma[:, k - 1]), np.degrees(run.omega[:, k - 1])])
        meta = {"attitude_type": "QUATERNION/ANGVEL", "angvel_frame": BODY_FRAME}
        lines = [f"agent {k} of {n}: body frame B = REF_FRAME_B; ANGVEL = omega of B relative to N, in B, deg/s"]
        jobs.append((name, meta, lines + common, rows))
    if reference_name_format is not None:
        name = _object_name(reference_name_format, **fields)
        lines = [f"reference attitude sigma_d: the reference frame D = REF_FRAME_B = {REFERENCE_FRAME}"]
        meta = {"attitude_type": "QUATERNION", "ref_frame_b": REFERENCE_FRAME}
        jobs.append((name, meta, lines + common, aem_quaternions(run.sigma_d)))
    return _write_all(Path(out_dir), header, inertial_frame, epochs, jobs, FORMATS[format], format)


def _write_all(out: Path, header, inertial_frame: str, epochs: list[str], jobs, suffix: str, format: str) -> list[Path]:
    paths = [out / f"{_slug(name)}{suffix}" for name, *_ in jobs]
    if len(set(paths)) != len(paths):
        raise AemError("two objects would share one file name: give an object name format with {k}")
    for path, (name, meta, comments, rows) in zip(paths, jobs, strict=True):
        frames = {"object_name": name, "object_id": name, "ref_frame_a": inertial_frame, "ref_frame_b": BODY_FRAME}
        try:
            text = _message(header, {**frames, **meta}, comments, epochs, rows).to_str(format)
        except (ccsds_ndm.NdmError, ValueError, TypeError) as exc:
            first = (str(exc).strip().splitlines() or [type(exc).__name__])[0]
            raise AemError(f"{name}: the AEM library refused the message ({first})") from None
        write_text(path, text)
    return paths


# ----------------------------------------------------------------------------- reading


@dataclass(frozen=True, eq=False)
class AttitudeEphemeris:
    """One object's attitude history as read from an AEM (:func:`read_aem`).

    Parameters
    ----------
    object_name, object_id : str
        ``OBJECT_NAME``, ``OBJECT_ID``.
    ref_frame_a, ref_frame_b : str
        The quaternion rotates ``ref_frame_a`` to ``ref_frame_b`` (:data:`QUATERNION_CONVENTION`).
    time_system : str
        ``TIME_SYSTEM`` of the epochs.
    attitude_type : str
        ``QUATERNION`` or ``QUATERNION/ANGVEL``.
    epoch : datetime.datetime
        The date of ``time = 0`` (naive, in ``time_system``).
    time : numpy.ndarray, shape (T,)
        Seconds since ``epoch``.
    quaternion : numpy.ndarray, shape (T, 4)
        ``Q1 Q2 Q3 QC`` (scalar last), as written.
    angular_velocity : numpy.ndarray or None, shape (T, 3)
        rad/s in ``angular_velocity_frame`` (converted from the file's deg/s); None without rates.
    angular_velocity_frame : str or None
        ``ANGVEL_FRAME``.
    comments : tuple of str
        Every comment line: header, metadata, data.
    provenance : Mapping of str to object
        The comments of the form ``key = <JSON value>`` (fsmctl's provenance and ``time_origin_utc``), and
        ``scenario_toml`` reassembled from its lines; empty for a file not written by fsmctl.
    quaternion_convention : str
        :data:`QUATERNION_CONVENTION`.

    Examples
    --------
    >>> import numpy as np
    >>> e = AttitudeEphemeris("a", "a", "EME2000", "SC_BODY_1", "UTC", "QUATERNION", DEFAULT_EPOCH,
    ...                       np.zeros(1), np.array([[0.0, 0.0, 1.0, 0.0]]))
    >>> e.sigma.tolist()  # 180 deg about z
    [[0.0, 0.0, 1.0]]
    """

    object_name: str
    object_id: str
    ref_frame_a: str
    ref_frame_b: str
    time_system: str
    attitude_type: str
    epoch: datetime
    time: np.ndarray
    quaternion: np.ndarray
    angular_velocity: np.ndarray | None = None
    angular_velocity_frame: str | None = None
    comments: tuple[str, ...] = ()
    provenance: Mapping[str, object] = field(default_factory=dict)
    quaternion_convention: str = QUATERNION_CONVENTION

    @property
    def sigma(self) -> np.ndarray:
        """(T, 3) MRPs (shadow set, ``|sigma| <= 1``) of the rotation ``ref_frame_a`` -> ``ref_frame_b``."""
        return mrp_from_aem_quaternions(self.quaternion)


def _parse(path: Path) -> ccsds_ndm.Aem:
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise NotAnAemError(f"{path}: cannot be read ({getattr(exc, 'strerror', None) or exc})") from None
    try:
        message = ccsds_ndm.from_str(text)
    except (ccsds_ndm.NdmError, ValueError, TypeError) as exc:
        first = (str(exc).strip().splitlines() or [type(exc).__name__])[0].rstrip(": ")
        raise NotAnAemError(f"{path}: not a CCSDS AEM ({first})") from None
    if not isinstance(message, ccsds_ndm.Aem):
        raise NotAnAemError(f"{path}: a CCSDS {type(message).__name__.upper()}, not an AEM")
    if not str(message.version).startswith("2"):
        raise AemError(f"{path}: AEM version {message.version}; only version 2 (CCSDS 504.0-B-2) is read")
    if len(message.segments) != 1:
        raise AemError(f"{path}: {len(message.segments)} segments; read_aem reads single-segment AEMs")
    return message


def _provenance(comments: Sequence[str]) -> dict[str, object]:
    texts: dict[str, str] = {}
    toml: list[str] = []
    for c in comments:
        if c.startswith(_TOML_PREFIX):
            toml.append(c[len(_TOML_PREFIX) :].removeprefix(" "))
        elif c.startswith(_TOML_MORE) and toml:
            toml[-1] += c[len(_TOML_MORE) :].removeprefix(" ")
        elif (m := _KEY_VALUE.match(c)) is not None:
            key, op, value = m.groups()
            texts[key] = texts.get(key, "") + value if op == "+=" else value
    out: dict[str, object] = {}
    for key, text in texts.items():
        try:
            out[key] = json.loads(text)
        except ValueError:
            continue
    if toml:
        out["scenario_toml"] = "\n".join(toml) + "\n"
    return out


def read_aem(path: str | Path, *, epoch: datetime | None = None) -> AttitudeEphemeris:
    """Read a single-segment quaternion AEM (version 2, KVN or XML) into an :class:`AttitudeEphemeris`.

    Parameters
    ----------
    path : str or Path
        The file.
    epoch : datetime.datetime, optional
        The date of ``time = 0``; by default the ``time_origin_utc`` that :func:`write_aem` records, else the
        first sample's epoch.

    Returns
    -------
    AttitudeEphemeris

    Raises
    ------
    NotAnAemError
        The file cannot be read, is not CCSDS, or is another CCSDS message.
    AemError
        An AEM this reader does not take: version 1, several segments, an attitude type other than
        ``QUATERNION`` or ``QUATERNION/ANGVEL``, an epoch that is not a calendar date.

    Examples
    --------
    >>> import tempfile, fsmctl
    >>> r = fsmctl.simulate(fsmctl.paper_scenario("1").replace(simulation={"t_final": 0.1}))
    >>> e = read_aem(write_aem(r, tempfile.mkdtemp())[-1])
    >>> e.object_name, e.attitude_type, e.angular_velocity is None, e.epoch.isoformat()
    ('paper-case-1-reference', 'QUATERNION', True, '2000-01-01T12:00:00')
    """
    path = Path(path)
    message = _parse(path)
    segment = message.segments[0]
    meta, data = segment.metadata, segment.data
    attitude_type = str(meta.attitude_type).upper()
    if attitude_type not in _QUATERNION_TYPES:
        raise AemError(f"{path}: ATTITUDE_TYPE {attitude_type}; read_aem reads QUATERNION and QUATERNION/ANGVEL")
    comments = (*message.header.comment, *meta.comment, *data.comment)
    prov = _provenance(comments)
    epochs = list(data.attitude_states_epochs)
    if not epochs:
        raise AemError(f"{path}: the AEM has no attitude state")
    origin = _utc_naive(epoch) if epoch is not None else _origin(prov, epochs[0], path)
    rows = np.asarray(data.attitude_states_numpy, dtype=float).reshape(len(epochs), -1)
    rates = _QUATERNION_TYPES[attitude_type]
    return AttitudeEphemeris(
        object_name=str(meta.object_name),
        object_id=str(meta.object_id),
        ref_frame_a=str(meta.ref_frame_a),
        ref_frame_b=str(meta.ref_frame_b),
        time_system=str(meta.time_system),
        attitude_type=attitude_type,
        epoch=origin,
        time=np.array([_seconds_since(origin, e) for e in epochs]),
        quaternion=rows[:, :4].copy(),
        angular_velocity=np.radians(rows[:, 4 : 4 + rates]) if rates else None,
        angular_velocity_frame=str(meta.angvel_frame) if rates else None,
        comments=tuple(str(c) for c in comments),
        provenance=prov,
    )


def _origin(prov: Mapping[str, object], first_epoch: str, path: Path) -> datetime:
    recorded = prov.get(_ORIGIN_KEY)
    if isinstance(recorded, str):
        try:
            return datetime.fromisoformat(recorded)
        except ValueError:
            raise AemError(f"{path}: {_ORIGIN_KEY} {recorded!r} is not an ISO date") from None
    return _calendar(first_epoch)[0]
