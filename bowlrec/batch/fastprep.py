"""Preparation at kernel speed for sweeps of the delivery: packed kernel inputs, run IDs and
scene JSON for a chunk of runs without building a Scene or a Plan per run.

A job qualifies when its base scene is physical and every swept path is one of
:data:`FAST_PATHS` (speed, take-off angle and the spin components: the fields a delivery sweep
varies). Those fields enter the Plan only through ``velocity0_mps`` and ``omega0_radps``, and
the rest of the Plan (ball, lane, options) is the base scene's, resolved once by
:meth:`~bowlrec.spec.Scene.resolve`; the two vectors are computed with the same operations in the
same order as :func:`bowlrec.spec.resolve.resolve_scene`, so the Plans, kernel inputs and run IDs
are bit-equal to resolving each scene (``tests/test_pipeline.py`` checks this on random points).
There is one resolution logic: this module reuses ``resolve()``'s result for everything it does
not vary.

No run is validated one by one: the fields' own constraints are intervals (speed > 0, angle in
(-90, 90), finite spin), checked by the job's validation on every grid or zip value and on both
ends of every random or Latin hypercube range, which covers every point between them; none of
these fields takes part in a check across fields.
"""

from __future__ import annotations

import hashlib
import json
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

import numpy as np
import pydantic_core

from bowlrec.archive.run_id import RUN_ID_LENGTH, canonical_plan
from bowlrec.batch.paths import apply_override, parse_path
from bowlrec.versions import PHYSICS_VERSION

if TYPE_CHECKING:
    from bowlrec.core.batch import PackedPlans
    from bowlrec.core.plan import Plan
    from bowlrec.spec import Scene

__all__ = ["FAST_PATHS", "FastChunk", "FastSweep"]

#: swept paths the fast preparation handles (element paths of the spin vector)
FAST_PATHS = (
    "delivery.speed_mps",
    "delivery.takeoff_angle_deg",
    "delivery.omega_radps[0]",
    "delivery.omega_radps[1]",
    "delivery.omega_radps[2]",
)

_MARK = "\x00M{}\x00"


_HEX_DIGITS = np.frombuffer(b"0123456789abcdef", dtype=np.uint8)


def float_hex(values: np.ndarray) -> np.ndarray:
    """``float.hex()`` of each float64 of ``values`` as bytes (numpy ``S``), computed for the
    whole array: sign, ``0x1.``, the 13 hex digits of the mantissa, ``p`` and the signed
    exponent. Zeros, subnormals, infinities and NaN take ``float.hex`` itself."""
    x = np.ascontiguousarray(values, dtype=np.float64)
    bits = x.view(np.uint64)
    biased = ((bits >> np.uint64(52)) & np.uint64(0x7FF)).astype(np.int64)
    shifts = np.arange(48, -4, -4, dtype=np.uint64)
    nibbles = (bits[:, None] >> shifts) & np.uint64(0xF)
    digits = _HEX_DIGITS[nibbles].view("S13").ravel()
    exponent = (biased - 1023).astype("S5")
    exponent = np.char.add(np.where(biased >= 1023, b"p+", b"p"), exponent)
    head = np.where(x < 0.0, b"-0x1.", b"0x1.")
    out = np.char.add(np.char.add(head, digits), exponent)
    odd = np.flatnonzero((biased == 0) | (biased == 0x7FF))
    if odd.size:
        out = out.astype(f"S{max(out.dtype.itemsize, 24)}")
        for i in odd.tolist():
            out[i] = float(x[i]).hex().encode()
    return out


class _Template:
    """JSON text with placeholders: literal pieces and, between them, which value goes there."""

    def __init__(
        self, text: str, n: int, quoted: bool, quote: Callable[[str], str] = json.dumps
    ) -> None:
        """``text`` holds the placeholder strings 0..n-1 once each, as ``quote`` writes them;
        ``quoted``: a value replaces the string with its quotes (a number goes there), else
        only its content."""
        marks = []
        for k in range(n):
            mark = quote(_MARK.format(k))
            mark = mark if quoted else mark[1:-1]
            marks.append((text.index(mark), k, mark))
        marks.sort()
        self.order = [k for _, k, _ in marks]
        self.pieces: list[str] = []
        pos = 0
        for at, _, mark in marks:
            self.pieces.append(text[pos:at])
            pos = at + len(mark)
        self.pieces.append(text[pos:])

    def fill(self, values: Sequence[str]) -> str:
        out = [self.pieces[0]]
        for piece, k in zip(self.pieces[1:], self.order, strict=True):
            out.append(values[k])
            out.append(piece)
        return "".join(out)


@dataclass(frozen=True)
class FastChunk:
    """Prepared runs ``index`` of a chunk: kernel inputs, run IDs, scene JSON and the swept
    values as given (``params``: path -> float64 array, NaN where a block does not sweep the
    path)."""

    index: np.ndarray
    params: dict[str, np.ndarray]
    packed: PackedPlans
    run_ids: list[str]
    scene_json: list[bytes]
    velocity0: np.ndarray
    omega0: np.ndarray

    def plan(self, i: int, base: Plan) -> Plan:
        """The full Plan of run ``i`` (for the rare run the batch kernel cannot report whole)."""
        return replace(
            base, velocity0_mps=self.velocity0[i].copy(), omega0_radps=self.omega0[i].copy()
        )


class FastSweep:
    """Fast preparation of a physical base scene's delivery sweep (see the module docs)."""

    def __init__(self, base_scene: Scene, paths: Sequence[str]) -> None:
        from bowlrec.core.batch import pack_plans

        self.paths = list(paths)
        self.scene = base_scene
        self.plan = base_scene.resolve()
        self._packed = pack_plans([self.plan])
        d = base_scene.delivery
        self.speed = float(d.speed_mps)
        self.angle_deg = float(d.takeoff_angle_deg)
        self.omega = np.asarray(d.omega_radps, dtype=np.float64)
        # run ID: the canonical Plan's JSON with the five varying numbers as fields
        canon = canonical_plan(self.plan)
        canon["velocity0_mps"]["data"] = [_MARK.format(0), _MARK.format(1)]
        canon["omega0_radps"]["data"] = [_MARK.format(k) for k in (2, 3, 4)]

        payload = json.dumps(
            {"physics_version": PHYSICS_VERSION, "plan": canon},
            sort_keys=True,
            separators=(",", ":"),
        )
        template = _Template(payload, 5, quoted=False)
        self._id_prefix = hashlib.sha256(template.pieces[0].encode())
        self._id_rest = [p.encode() for p in template.pieces[1:]]
        self._id_order = template.order
        # scene JSON: the base scene with the swept fields as fields, serialized as
        # Scene.model_dump_json() writes it (pydantic's own float text), so a run stores the
        # same bytes whichever path prepared it
        data = base_scene.model_dump(mode="json")
        #: how a segment stores the chunk's scenes (format 2.3): this base, and per run the
        #: swept values at these paths
        self.scene_base = pydantic_core.to_json(data)
        self.scene_paths: list[list[str | int]] = [list(parse_path(p)) for p in self.paths]
        for k, path in enumerate(self.paths):
            apply_override(data, path, _MARK.format(k))
        self._scene_template = _Template(
            pydantic_core.to_json(data).decode(),
            len(self.paths),
            quoted=True,
            quote=lambda mark: pydantic_core.to_json(mark).decode(),
        )

    def _run_ids(self, values: np.ndarray) -> list[str]:
        """SHA-256 of the canonical Plan (:func:`bowlrec.archive.run_id.run_id`) of each run
        whose five varying numbers are a row of ``values`` (n, 5: velocity x, y, spin x, y,
        z). The payload after the shared prefix is assembled for all runs at once."""
        hexes = [float_hex(values[:, k]) for k in range(values.shape[1])]
        rest = hexes[self._id_order[0]]
        for piece, k in zip(self._id_rest[:-1], self._id_order[1:], strict=True):
            rest = np.char.add(np.char.add(rest, piece), hexes[k])
        rest = np.char.add(rest, self._id_rest[-1])
        prefix = self._id_prefix
        out = []
        for payload in rest.tolist():
            h = prefix.copy()
            h.update(payload)
            out.append(h.hexdigest()[:RUN_ID_LENGTH])
        return out

    @staticmethod
    def applies(bowler: bool, paths: Sequence[str], has_scenes: bool) -> bool:
        """True when a job with these properties can be prepared by this class."""
        return not bowler and not has_scenes and bool(paths) and set(paths) <= set(FAST_PATHS)

    def prepare(
        self, index: np.ndarray, columns: dict[str, np.ndarray], *, scenes: bool = True
    ) -> FastChunk:
        """Kernel inputs, run IDs and scene JSON of the runs whose swept values are
        ``columns`` (path -> float64 array; NaN: the base scene's value). ``scenes`` False
        skips the scene JSON (``scene_json`` is empty: a segment stores :attr:`scene_base` and
        the swept values instead)."""
        from bowlrec.core.batch import PackedPlans

        n = int(index.shape[0])
        given = {p: np.asarray(columns[p], dtype=np.float64) for p in self.paths}
        params = {}  # with the base's value where a block does not sweep the path
        for p, col in given.items():
            missing = np.isnan(col)
            params[p] = np.where(missing, self._base_value(p), col) if missing.any() else col
        speed, angle = params.get("delivery.speed_mps"), params.get("delivery.takeoff_angle_deg")
        omega = np.empty((n, 3))
        omega[:] = self.omega
        for k in range(3):
            spin = params.get(f"delivery.omega_radps[{k}]")
            if spin is not None:
                omega[:, k] = spin
        velocity = np.empty((n, 2))
        speeds = speed.tolist() if speed is not None else [self.speed] * n
        angles = angle.tolist() if angle is not None else [self.angle_deg] * n
        cos, sin, radians = math.cos, math.sin, math.radians
        vx = [0.0] * n
        vy = [0.0] * n
        for i in range(n):  # math, as resolve_scene computes them (bit-equal)
            a = radians(angles[i])
            vx[i] = speeds[i] * cos(a)
            vy[i] = speeds[i] * sin(a)
        velocity[:, 0] = vx
        velocity[:, 1] = vy
        base = self._packed
        y0 = np.repeat(base.y0, n, axis=0)
        y0[:, 2:4] = velocity
        y0[:, 8:11] = omega
        packed = PackedPlans(
            par=np.repeat(base.par, n, axis=0),
            y0=y0,
            x_edges=np.tile(base.x_edges, n),
            x_off=np.arange(n + 1, dtype=np.int64) * base.x_edges.size,
            y_edges=np.tile(base.y_edges, n),
            y_off=np.arange(n + 1, dtype=np.int64) * base.y_edges.size,
            mu=np.tile(base.mu, n),
            mu_off=np.arange(n + 1, dtype=np.int64) * base.mu.size,
            lane=np.repeat(base.lane, n, axis=0),
            opts=np.repeat(base.opts, n, axis=0),
            flags=np.repeat(base.flags, n, axis=0),
        )
        run_ids = self._run_ids(np.concatenate([velocity, omega], axis=1))
        fill = self._scene_template.fill
        lists = [params[p].tolist() for p in self.paths]
        text = pydantic_core.to_json
        scene_json = (
            [fill([text(v).decode() for v in vals]).encode() for vals in zip(*lists, strict=True)]
            if scenes
            else []
        )
        return FastChunk(index, given, packed, run_ids, scene_json, velocity, omega)

    def _base_value(self, path: str) -> float:
        if path == "delivery.speed_mps":
            return self.speed
        if path == "delivery.takeoff_angle_deg":
            return self.angle_deg
        return float(self.omega[int(path[-2])])
