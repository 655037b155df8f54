"""One run as one self-describing HDF5 file (format ``bowlrec-run``, see docs/archive-format.md).

Layout (every dataset has a ``units`` attribute; arrays are chunked, gzip level 4 + shuffle):

- ``/`` attributes: ``format``, ``format_version``, ``run_id``, ``name``, ``scene_json`` (the
  scene as given), ``summary_json``, ``ball_ref`` and the provenance (versions, solver settings,
  wall time, created-at).
- ``/resolved/<field>``: every field of the resolved :class:`~bowlrec.core.plan.Plan`.
- ``/trajectory/<quantity>``: one dataset per per-sample quantity (first axis = sample);
  ``/trajectory/torques/<term>`` when per-term torques were recorded.
- ``/events/{t_s,kind,x_m,y_m,mu,phase}``: one row per event.
- ``/summary``: the summary metrics as attributes (absent when None).
- ``/pins`` (format 1.1; only for a run with pin action, ``options.pins``): the pins' recorded
  motion as the archive's ``pins/`` group holds it (``t_s``, ``pin_position_m``,
  ``pin_quaternion_wxyz``, ``ball_position_m``, ``ball_quaternion_wxyz``, ``energy_J``; pin p is
  column p - 1, NaN for a pin not set), and the archive's one-row groups without their row axis:
  ``/pins/outcome/*``, ``/pins/action/*``, ``/pins/entry/*``, ``/pins/extras/{name,value}``
  (:mod:`bowlrec.pins.records`); attribute ``outcome_json`` (``PinOutcome.to_dict()``).
  The resolved pin model is the ``/resolved`` attribute ``pins_json``. A run without pins is
  written exactly as by format 1.0 and declares 1.0.

Files are written with the default ``libver`` (readable by HDF5 1.10-era tools; ``"latest"``
in h5py 3.16 / HDF5 2.0 writes structures older readers reject) and whole-or-nothing through
:func:`~bowlrec.atomic_files.atomic_path`.
"""

from __future__ import annotations

import dataclasses
import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import h5py
import numpy as np

from bowlrec.atomic_files import atomic_path
from bowlrec.core.trajectory import Event, Summary, Trajectory
from bowlrec.errors import RunFileError
from bowlrec.provenance import environment
from bowlrec.units import DIMENSIONLESS, units_for

from .common import RunData, dumps

if TYPE_CHECKING:
    from bowlrec.pins.outcome import PinOutcome
    from bowlrec.spec import Scene

__all__ = [
    "FORMAT_NAME",
    "FORMAT_VERSION",
    "GZIP_FILTERS",
    "PINS_FORMAT_VERSION",
    "RunFileError",
    "StoredRun",
    "read_run_file",
    "read_run_header",
    "write_run",
    "write_run_file",
]

FORMAT_NAME = "bowlrec-run"
#: major.minor: readers accept any minor of their major; a major change breaks old readers
FORMAT_VERSION = "1.0"
#: the minor version a run file declares when it holds the run's pins (``/pins``)
PINS_FORMAT_VERSION = "1.1"

#: the one compression of bowlrec's HDF5 files (run files here, archive segments): shuffle +
#: gzip level 4 (sizes and read times: benchmarks/results/archive.md)
GZIP_FILTERS: dict[str, Any] = {"compression": "gzip", "compression_opts": 4, "shuffle": True}
_EVENT_FIELDS = ("t_s", "kind", "x_m", "y_m", "mu", "phase")
_STR = h5py.string_dtype("utf-8")


@dataclass(frozen=True)
class StoredRun:
    """A run read back from its file: the scene, the trajectory and the root attributes."""

    run_id: str
    scene: Scene
    trajectory: Trajectory
    #: root attributes (format, versions, solver settings, wall time, created-at, ball_ref, ...)
    attrs: dict[str, Any]
    #: per-run record groups of an archived run (archive format 2.1): group -> {dataset: rows}
    records: dict[str, dict[str, Any]] = field(default_factory=dict)

    @property
    def ball_ref(self) -> str | None:
        ref = self.attrs.get("ball_ref", "")
        return str(ref) or None


def _dataset(group: h5py.Group, name: str, data: Any, units_name: str | None = None) -> None:
    arr = np.asarray(data)
    chunked = arr.ndim >= 1 and arr.size > 0  # HDF5 cannot chunk scalars or empty arrays
    opts: dict[str, Any] = {"chunks": True, **GZIP_FILTERS} if chunked else {}
    ds = group.create_dataset(name, data=arr, **opts)
    key = units_name or name
    ds.attrs["units"] = units_for(key)
    if key in DIMENSIONLESS:
        ds.attrs["meaning"] = DIMENSIONLESS[key]


def _write_resolved(group: h5py.Group, run: RunData) -> None:
    from bowlrec.core.plan import external_field_at_default

    for f in dataclasses.fields(run.plan):
        value = getattr(run.plan, f.name)
        if external_field_at_default(run.plan, f.name):
            continue  # an optional external term that is off (as the run ID leaves it out)
        if f.name == "labels":
            group.attrs["labels_json"] = json.dumps(value, sort_keys=True)
        elif f.name == "pins" and value is not None:
            group.attrs["pins_json"] = json.dumps(dataclasses.asdict(value), sort_keys=True)
        elif value is None:
            group.attrs[f"{f.name}_is_none"] = True
        else:
            _dataset(group, f.name, value)


def _write_trajectory(group: h5py.Group, traj: Trajectory) -> None:
    for name, arr in traj.arrays().items():
        if name.startswith("torque_"):
            continue
        _dataset(group, name, arr)
    group.attrs["n_samples"] = traj.n_samples
    if traj.torques_Nm:
        tg = group.create_group("torques")
        tg.attrs["order"] = list(traj.torques_Nm)
        for term, arr in traj.torques_Nm.items():
            _dataset(tg, term, arr, units_name="torque_Nm")


def _write_events(group: h5py.Group, events: list[Event]) -> None:
    for name in _EVENT_FIELDS:
        values = [getattr(e, name) for e in events]
        if name in ("kind", "phase"):
            ds = group.create_dataset(name, data=np.array(values, dtype=object), dtype=_STR)
            ds.attrs["units"] = "1"
        else:
            _dataset(group, name, np.asarray(values, dtype=np.float64), units_name=name)


def _write_summary(group: h5py.Group, summary: Summary) -> None:
    for key, value in summary.to_dict().items():
        if value is not None:
            group.attrs[key] = value


#: the archive's pin record groups (bowlrec.pins.records) -> their group in ``/pins``
#: ("": the per-sample datasets, in ``/pins`` itself)
_PIN_GROUPS = {
    "pin_outcome": "outcome",
    "pin_action": "action",
    "pin_entry": "entry",
    "pins": "",
    "pin_extras": "extras",
}
#: groups of one row in the archive, written here without their row axis
_PIN_ONE_ROW = ("pin_outcome", "pin_action", "pin_entry")


def _write_pins(group: h5py.Group, outcome: PinOutcome) -> None:
    from bowlrec.pins.records import PIN_MEANINGS, pin_groups

    group.attrs["outcome_json"] = dumps(outcome.to_dict())
    for record, datasets in pin_groups(outcome).items():
        sub = group.require_group(_PIN_GROUPS[record]) if _PIN_GROUPS[record] else group
        for name, arr in datasets.items():
            data = arr[0] if record in _PIN_ONE_ROW else arr
            units, meaning = PIN_MEANINGS.get(f"{record}/{name}", (None, None))
            if data.dtype.kind == "S":  # text: UTF-8 strings, as the events' kinds
                text = np.array([b.decode() for b in data.ravel()], dtype=object)
                ds = sub.create_dataset(name, data=text.reshape(data.shape), dtype=_STR)
            else:
                opts = {"chunks": True, **GZIP_FILTERS} if data.ndim and data.size else {}
                ds = sub.create_dataset(name, data=data, **opts)
            ds.attrs["units"] = units or units_for(name)
            if meaning is not None:
                ds.attrs["meaning"] = meaning


def _read_pins(group: h5py.Group) -> PinOutcome | None:
    from bowlrec.pins.records import pin_outcome_of

    records: dict[str, dict[str, Any]] = {}
    for record, where in _PIN_GROUPS.items():
        if where and where not in group:
            continue
        sub = group[where] if where else group
        rows: dict[str, Any] = {}
        for name, ds in sub.items():
            if not isinstance(ds, h5py.Dataset):
                continue
            if h5py.check_string_dtype(ds.dtype) is not None:
                value = np.char.encode(np.asarray(ds.asstr()[()], dtype=np.str_), "utf-8")
            else:
                value = ds[()]
            rows[name] = np.asarray(value)[None] if record in _PIN_ONE_ROW else value
        records[record] = rows
    return pin_outcome_of(records)


def write_run_file(
    path: str | Path, run: RunData, attrs: dict[str, Any], *, durable: bool = True
) -> Path:
    """Write ``run`` to ``path`` whole or not at all; ``attrs`` become root attributes.

    ``attrs`` holds the provenance (see :mod:`bowlrec.provenance`); values must be
    str, int, float or bool. Returns the final path.
    """
    path = Path(path)
    with atomic_path(path, durable=durable) as tmp, h5py.File(tmp, "w") as f:
        f.attrs["format"] = FORMAT_NAME
        pins = run.trajectory.pins
        f.attrs["format_version"] = FORMAT_VERSION if pins is None else PINS_FORMAT_VERSION
        f.attrs["run_id"] = run.run_id or ""
        f.attrs["name"] = run.scene.name
        f.attrs["scene_json"] = run.scene_json()
        f.attrs["summary_json"] = dumps(run.trajectory.summary.to_dict())
        for key, value in attrs.items():
            f.attrs[key] = value
        _write_resolved(f.create_group("resolved"), run)
        _write_trajectory(f.create_group("trajectory"), run.trajectory)
        _write_events(f.create_group("events"), run.trajectory.events)
        _write_summary(f.create_group("summary"), run.trajectory.summary)
        if pins is not None:
            if pins.action is not None and "pin_engine_version" not in attrs:
                f.attrs["pin_engine_version"] = pins.action.engine
            _write_pins(f.create_group("pins"), pins)
    return path


def write_run(run: RunData, path: str | Path) -> Path:
    """Write ``run`` to ``path`` as a run file (the registry's writer); its provenance is the
    run's own (:attr:`RunData.provenance`, for an archived run) or, for a run never archived,
    this process's versions and platform. Returns the final path."""

    attrs = dict(run.provenance) if run.provenance is not None else environment()
    return write_run_file(path, run, attrs)


def _check_format(f: h5py.File, path: Path) -> None:
    fmt = f.attrs.get("format")
    version = str(f.attrs.get("format_version", ""))
    if fmt != FORMAT_NAME:
        raise RunFileError(f"{path}: not a bowlrec run file (format = {fmt!r})")
    if version.split(".")[0] != FORMAT_VERSION.split(".")[0]:
        raise RunFileError(
            f"{path}: run format version {version} is not supported by this reader "
            f"(supports {FORMAT_VERSION.split('.')[0]}.x)"
        )


def _attrs(f: h5py.File) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for key, value in f.attrs.items():
        out[key] = value.item() if isinstance(value, np.generic) else value
    return out


def read_run_header(path: str | Path) -> dict[str, Any]:
    """The root attributes of a run file (checks the format), without reading any array."""
    path = Path(path)
    with h5py.File(path, "r") as f:
        _check_format(f, path)
        return _attrs(f)


def _read_events(group: h5py.Group) -> list[Event]:
    n = group["t_s"].shape[0]
    cols = {
        name: (group[name].asstr()[()] if name in ("kind", "phase") else group[name][()])
        for name in _EVENT_FIELDS
    }
    return [
        Event(
            t_s=float(cols["t_s"][i]),
            kind=str(cols["kind"][i]),
            x_m=float(cols["x_m"][i]),
            y_m=float(cols["y_m"][i]),
            mu=float(cols["mu"][i]),
            phase=str(cols["phase"][i]),
        )
        for i in range(n)
    ]


def read_run_file(path: str | Path) -> StoredRun:
    """Read a run file back: the Scene (equal to the one written) and the Trajectory, with its
    ``pins`` (the :class:`~bowlrec.pins.outcome.PinOutcome` written, format 1.1) or None.

    Arrays come back with the dtypes and values that were written (bit-for-bit).
    """
    from bowlrec.spec import Scene

    path = Path(path)
    with h5py.File(path, "r") as f:
        _check_format(f, path)
        attrs = _attrs(f)
        tg = f["trajectory"]
        arrays = {name: tg[name][()] for name in tg if isinstance(tg[name], h5py.Dataset)}
        torques: dict[str, Any] = {}
        if "torques" in tg:
            for term in tg["torques"].attrs["order"]:
                torques[str(term)] = tg["torques"][term][()]
        events = _read_events(f["events"])
        pins = _read_pins(f["pins"]) if "pins" in f else None
    summary = Summary(**json.loads(attrs["summary_json"]))
    traj = Trajectory(**arrays, events=events, summary=summary, torques_Nm=torques, pins=pins)
    scene = Scene.model_validate_json(attrs["scene_json"])
    return StoredRun(run_id=str(attrs["run_id"]), scene=scene, trajectory=traj, attrs=attrs)
