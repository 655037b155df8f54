"""The result of one delivery: samples (struct of arrays), events and the summary. Plain NumPy."""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field, replace
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from bowlrec.errors import MissingExtraError

if TYPE_CHECKING:
    import pandas as pd

    from bowlrec.pins.outcome import PinOutcome

#: the Summary's float metrics, as columns of many runs (NaN: no value)
FLOAT_METRICS = (
    "slide_m",
    "hook_m",
    "pocket_deg",
    "time_s",
    "x_end_m",
    "y_end_m",
    "speed_end_mps",
    "rev_rate_end_rpm",
)
#: the Summary's integer metrics
INT_METRICS = ("n_steps", "n_rhs", "n_events")


@dataclass(frozen=True)
class Event:
    """Something that happened at one instant: a phase change, a zone crossing or the end."""

    t_s: float
    kind: str
    x_m: float
    y_m: float
    #: friction coefficient under the ball after the event
    mu: float
    #: "rolling" or "sliding" after the event
    phase: str


@dataclass(frozen=True, repr=False)
class Summary:
    """Table III quantities and the run's bookkeeping.

    hook_m: leftward (+y) deflection at the pins relative to the straight line along the initial
    velocity; pocket_deg: angle of the velocity to the x axis at the pins (positive toward the
    left); slide_m: x where rolling first starts (the release x for a ball released rolling,
    None if the ball never rolls). hook_m and pocket_deg are None unless the outcome is "pins".
    message: the outcome in one line of words. The core leaves it empty (it reports codes and
    numbers); :func:`bowlrec.core.solver.run_plan` and the batch engine fill it
    (:func:`bowlrec.core.outcome.outcome_message`), so every archived or printed run has it.
    """

    outcome: str
    message: str
    slide_m: float | None
    hook_m: float | None
    pocket_deg: float | None
    time_s: float
    x_end_m: float
    y_end_m: float
    speed_end_mps: float
    rev_rate_end_rpm: float
    n_steps: int
    n_rhs: int
    n_events: int

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)

    def __repr__(self) -> str:
        """One line: the outcome, the Table III metrics, the time (s) and where the ball ended
        (m); the message and the step counts are left out."""
        return (
            f"Summary(outcome={self.outcome!r}, slide_m={_short(self.slide_m)}, "
            f"hook_m={_short(self.hook_m)}, pocket_deg={_short(self.pocket_deg)}, "
            f"time_s={_short(self.time_s)}, end=({_short(self.x_end_m)}, "
            f"{_short(self.y_end_m)}) m)"
        )


@dataclass(frozen=True)
class Observation:
    """The state where the path reached an observed station x or turned across the lane
    (v_y = 0); lane frame, SI units (:mod:`bowlrec.core.observe`)."""

    t_s: float
    #: index of the station in the requested stations, or OBS_TURN (-1) for a turning point,
    #: OBS_RELEASE (-2) for the release, OBS_END (-3) for the run's last state (core.codes)
    station: int
    position_m: tuple[float, float]
    velocity_mps: tuple[float, float]
    omega_radps: tuple[float, float, float]


#: the per-sample quantities :func:`bowlrec.core.solver.sample_arrays` derives from the state
#: (the other per-sample fields and ``friction_dir``)
DERIVED_SAMPLE_FIELDS = (
    "alpha_radps2",
    "energy_J",
    "friction_force_N",
    "normal_force_N",
    "slip_mps",
)
#: the per-sample state the kernel records (with ``friction_dir`` it gives the rest), sorted
STATE_SAMPLE_FIELDS = (
    "friction_dir",
    "mu",
    "omega_radps",
    "phase",
    "position_m",
    "quaternion_wxyz",
    "t_s",
    "velocity_mps",
)
#: the per-sample fields a derivation mark covers (the state and what it gives)
_MARKED_FIELDS = (*DERIVED_SAMPLE_FIELDS, *STATE_SAMPLE_FIELDS)


@dataclass(repr=False)
class Trajectory:
    """Samples of one delivery (lane frame, SI units) plus its events and summary.

    position_m is the geometric center (z = 0 is the center plane; the lane surface is z = -R),
    velocity_mps its velocity, quaternion_wxyz the body->lane rotation, omega_radps the angular
    velocity in the lane frame, phase 0 sliding / 1 rolling, mu the friction under the ball,
    normal_force_N and friction_force_N the contact force, slip_mps the slip R_con x w - v,
    energy_J the mechanical energy. torques_Nm maps each term of Eqs. (6)/(7) to an (n, 3) array
    when per-term recording was asked for (inertia terms as I_k alpha, in N m).
    """

    t_s: NDArray[np.float64]
    position_m: NDArray[np.float64]
    velocity_mps: NDArray[np.float64]
    quaternion_wxyz: NDArray[np.float64]
    omega_radps: NDArray[np.float64]
    phase: NDArray[np.int8]
    mu: NDArray[np.float64]
    normal_force_N: NDArray[np.float64]
    friction_force_N: NDArray[np.float64]
    slip_mps: NDArray[np.float64]
    energy_J: NDArray[np.float64]
    alpha_radps2: NDArray[np.float64]
    events: list[Event]
    summary: Summary
    torques_Nm: dict[str, NDArray[np.float64]] = field(default_factory=dict)
    #: observed stations and turning points, in time order (empty unless asked for)
    observations: list[Observation] = field(default_factory=list)
    #: the pins after the ball when the scene asked for pin action (options.pins), else None
    pins: PinOutcome | None = None
    #: (n, 2) unit direction (x, y) of the sliding friction force as the kernel applied it (a
    #: sample's slip direction at the start of its step); with the state above it gives every
    #: other per-sample quantity again (:func:`bowlrec.core.solver.sample_arrays`); None when
    #: not known (e.g. a run file's trajectory)
    friction_dir: NDArray[np.float64] | None = None

    def mark_derived_from_state(self) -> Trajectory:
        """Record that the derived per-sample arrays (:data:`DERIVED_SAMPLE_FIELDS`) are exactly
        what :func:`bowlrec.core.solver.sample_arrays` gives from the state (the kernel or a
        reader computed them so): the per-sample arrays become read-only, and
        :meth:`derived_from_state` says so while the trajectory holds these same arrays (a
        trajectory made with ``dataclasses.replace`` is not marked). Returns the trajectory."""
        if self.friction_dir is None:
            return self
        arrays = tuple(getattr(self, k) for k in _MARKED_FIELDS)
        for arr in arrays:
            arr.flags.writeable = False
        # an instance attribute, not a field: the fields stay the trajectory's data
        self.__dict__["_marked"] = arrays
        return self

    def derived_from_state(self) -> bool:
        """Whether the derived per-sample arrays are known to be exactly what the state gives
        (:meth:`mark_derived_from_state`): an archive then stores the state alone without
        deriving them again to compare."""
        marked = self.__dict__.get("_marked")
        return marked is not None and all(
            getattr(self, k) is arr and not arr.flags.writeable
            for k, arr in zip(_MARKED_FIELDS, marked, strict=True)
        )

    def replaced(self, **changes: Any) -> Trajectory:
        """``dataclasses.replace(self, **changes)``, marked as derived from its state when this
        trajectory is and no per-sample field changes (e.g. a new summary or pins)."""
        out = replace(self, **changes)
        if self.derived_from_state() and not set(changes) & set(_MARKED_FIELDS):
            out.mark_derived_from_state()
        return out

    @property
    def n_samples(self) -> int:
        return int(self.t_s.shape[0])

    @property
    def speed_mps(self) -> NDArray[np.float64]:
        return np.asarray(np.linalg.norm(self.velocity_mps, axis=1))

    def arrays(self) -> dict[str, NDArray[Any]]:
        """All per-sample arrays by name (torques as ``torque_<term>``)."""
        out: dict[str, NDArray[Any]] = {
            "t_s": self.t_s,
            "position_m": self.position_m,
            "velocity_mps": self.velocity_mps,
            "quaternion_wxyz": self.quaternion_wxyz,
            "omega_radps": self.omega_radps,
            "phase": self.phase,
            "mu": self.mu,
            "normal_force_N": self.normal_force_N,
            "friction_force_N": self.friction_force_N,
            "slip_mps": self.slip_mps,
            "energy_J": self.energy_J,
            "alpha_radps2": self.alpha_radps2,
        }
        for name, arr in self.torques_Nm.items():
            out[f"torque_{name}"] = arr
        return out

    def to_dataframe(self) -> pd.DataFrame:
        """The samples as a pandas DataFrame, one row per sample, with the columns of
        :func:`sample_columns` (named with their units: ``t_s``, ``x_m``, ``omega_x_radps``,
        ``normal_force_N``, ...; values equal to the arrays). A trajectory without samples (a
        summary-only run) gives one row of :meth:`Summary.to_dict` instead, a metric without a
        value as NaN.

        Needs pandas (``pip install 'bowlrec[pandas]'``); :class:`MissingExtraError` otherwise.
        """
        try:
            import pandas as pd
        except ImportError:
            raise MissingExtraError(
                "Trajectory.to_dataframe needs pandas, which is not installed; install it with: "
                "pip install 'bowlrec[pandas]'",
                name="pandas",
            ) from None
        if self.n_samples == 0:
            row = {k: math.nan if v is None else v for k, v in self.summary.to_dict().items()}
            return pd.DataFrame([row])
        return pd.DataFrame(sample_columns(self))

    def __repr__(self) -> str:
        """One line: outcome, sample count and time span (s), Table III metrics, event count."""
        s = self.summary
        if self.n_samples:
            span = f"t={_short(float(self.t_s[0]))}..{_short(float(self.t_s[-1]))} s"
        else:
            span = f"time_s={_short(s.time_s)}"
        terms = f", terms={len(self.torques_Nm)}" if self.torques_Nm else ""
        return (
            f"Trajectory(outcome={s.outcome!r}, samples={self.n_samples}, {span}, "
            f"slide_m={_short(s.slide_m)}, hook_m={_short(s.hook_m)}, "
            f"pocket_deg={_short(s.pocket_deg)}, events={len(self.events)}{terms})"
        )


def _short(value: float | None) -> str:
    """``value`` to 4 significant digits for a repr; ``None`` as is."""
    return "None" if value is None else f"{value:.4g}"


#: lane-frame axis of each vector component, in column order
_XYZ = ("x", "y", "z")
#: Trajectory array -> its sample columns, in order (each named with its unit)
_COLUMN_NAMES: tuple[tuple[str, tuple[str, ...]], ...] = (
    ("t_s", ("t_s",)),
    ("position_m", ("x_m", "y_m", "z_m")),
    ("velocity_mps", ("vx_mps", "vy_mps", "vz_mps")),
    ("quaternion_wxyz", ("q_w", "q_x", "q_y", "q_z")),
    ("omega_radps", tuple(f"omega_{a}_radps" for a in _XYZ)),
    ("phase", ("phase",)),
    ("mu", ("mu",)),
    ("normal_force_N", ("normal_force_N",)),
    ("friction_force_N", tuple(f"friction_{a}_N" for a in _XYZ)),
    ("slip_mps", tuple(f"slip_{a}_mps" for a in _XYZ)),
    ("energy_J", ("energy_J",)),
    ("alpha_radps2", tuple(f"alpha_{a}_radps2" for a in _XYZ)),
)


def sample_columns(traj: Trajectory) -> dict[str, NDArray[Any]]:
    """The samples of ``traj`` as scalar columns (n,), by name, in the order of
    :meth:`Trajectory.arrays` with vectors split by component; the one column naming shared by
    the CSV file (:mod:`bowlrec.sinks.csv_file`) and :meth:`Trajectory.to_dataframe`.

    Each name ends in its unit (:func:`bowlrec.units.units_for`) or is dimensionless:
    ``t_s``; ``x_m``, ``y_m``, ``z_m`` (center, lane frame); ``vx_mps`` ...; ``q_w``, ``q_x``,
    ``q_y``, ``q_z`` (body -> lane quaternion); ``omega_x_radps`` ...; ``phase`` (0 sliding,
    1 rolling); ``mu``; ``normal_force_N``; ``friction_x_N`` ...; ``slip_x_mps`` ...;
    ``energy_J``; ``alpha_x_radps2`` ...; and when per-term torques were recorded
    ``<term>_x_Nm`` ... for each term of :attr:`Trajectory.torques_Nm` (``tau_dev_x_Nm``,
    ``I_o_x_Nm``, ...). Values are the arrays' own (views, same dtype: float64, phase int8).
    """
    n = traj.n_samples
    named = [(getattr(traj, attr), names) for attr, names in _COLUMN_NAMES]
    named += [(arr, tuple(f"{term}_{a}_Nm" for a in _XYZ)) for term, arr in traj.torques_Nm.items()]
    out: dict[str, NDArray[Any]] = {}
    for arr, names in named:
        block = np.asarray(arr).reshape(n, len(names))
        for i, name in enumerate(names):
            out[name] = block[:, i]
    return out


def summary_trajectory(events: list[Event], summary: Summary) -> Trajectory:
    """A Trajectory without samples (a summary-only run): its events and summary."""
    return Trajectory(
        t_s=np.zeros(0),
        position_m=np.zeros((0, 3)),
        velocity_mps=np.zeros((0, 3)),
        quaternion_wxyz=np.zeros((0, 4)),
        omega_radps=np.zeros((0, 3)),
        phase=np.zeros(0, dtype=np.int8),
        mu=np.zeros(0),
        normal_force_N=np.zeros(0),
        friction_force_N=np.zeros((0, 3)),
        slip_mps=np.zeros((0, 3)),
        energy_J=np.zeros(0),
        alpha_radps2=np.zeros((0, 3)),
        events=events,
        summary=summary,
    )
