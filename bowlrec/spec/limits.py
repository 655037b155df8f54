"""Hard limits of a physical scene: generous, finite bounds that keep every computed value
finite and every run's work bounded (SI units).

They are physical plausibility bounds, far outside anything bowled, not rules: the USBC limits
(ball weight, size, RG, differential) live in the bowlers' layer
(:mod:`bowlrec.bowling.legality`, ``allow_illegal``), because the paper's own cases and the
stress tests go beyond legal on purpose. Every limit is in the JSON Schemas (``maximum``) and
in the field's description, and an input beyond one is refused with the field's name, the value
and the allowed range.

Why each bound:

* speed 100 m/s: about 8x the fastest delivery ever bowled (~12 m/s); beyond it air drag, which
  the model leaves out, would dominate.
* spin 1000 rad/s per component (9,549 rpm): about 13x the highest rev rates (~75 rad/s); the
  surface of a 0.1085 m ball would move at 108 m/s.
* mass 100 kg, radius 1 m: ~14x and ~9x a bowling ball; they keep moments of inertia and normal
  forces finite.
* mu 10: dry rubber on concrete is about 1 and a lane 0.04-0.3.
* lane 10 km long and wide: the stress tests roll a ball 1.8 km on a 2 km wide lane.
* g 100 m/s^2: 10 g.
* max_time_s 10,000 s: the longest stress test runs 430 s of simulated time.
* samples per run 2,000,000: the integrator's step limit, so ``record: steps`` (one sample per
  step) and ``record: rate`` (max_time_s / record_dt_s samples, plus one at each event) have
  the same bound: 2,000,000 samples of 16 float64 values are 256 MB; a run that records them
  needs several times that while it is simulated (benchmarks/results/hardening.md, "The
  largest recording allowed").
* friction zones 256: a zone map becomes a grid of up to (2n + 1)^2 cells.
* lane slope |dz/dy| <= 1e-3 (cross tilt plus height profile): the small-slope approximation
  (gravity's lateral component added, the contact geometry kept flat) is good to O(slope^2),
  ~1e-6; USBC's legal cross tilt is 0.040 in over 41.5 in, ~1e-3. A height profile has at most
  256 points (about 6 per board).
* rolling-resistance coefficient 0.1: hard rubber on steel is ~1e-3, a car tire on asphalt
  ~0.01; 0.1 is a soft wheel in sand.
* drag coefficient 2 and air density 10 kg/m^3: a sphere's C_D is 0.1-0.5 above Re 1e3 (about
  2 is a flat plate); air at sea level is 1.2 kg/m^3.
"""

from __future__ import annotations

__all__ = [
    "MAX_G_MPS2",
    "MAX_GRID_EDGES",
    "MAX_LANE_M",
    "MAX_MASS_KG",
    "MAX_MU",
    "MAX_OMEGA_RADPS",
    "MAX_RADIUS_M",
    "MAX_SAMPLES_PER_RUN",
    "MAX_SPEED_MPS",
    "MAX_TIME_S",
    "MAX_ZONES",
    "MAX_SLOPE",
    "MIN_RG_FRACTION",
    "MAX_PROFILE_POINTS",
    "MAX_ROLLING_RESISTANCE",
    "MAX_DRAG_COEFFICIENT",
    "MAX_AIR_DENSITY",
]

MAX_SPEED_MPS = 100.0
MAX_OMEGA_RADPS = 1000.0
MAX_MASS_KG = 100.0
MAX_RADIUS_M = 1.0
#: the smallest radius of gyration, as a fraction of the radius: below it (a ball nearly all
#: of whose mass sits at its centre) the slip's relaxation, ~ mu g (1 + R^2 / k^2), is too stiff
#: for the integrator (rg = 1e-6 m in a 0.1085 m ball stalled; 1e-5 m still integrates)
MIN_RG_FRACTION = 1e-3
MAX_MU = 10.0
MAX_LANE_M = 10_000.0
MAX_G_MPS2 = 100.0
MAX_TIME_S = 10_000.0
MAX_SAMPLES_PER_RUN = 2_000_000
MAX_ZONES = 256
MAX_GRID_EDGES = 4096
MAX_SLOPE = 1e-3
MAX_PROFILE_POINTS = 256
MAX_ROLLING_RESISTANCE = 0.1
MAX_DRAG_COEFFICIENT = 2.0
MAX_AIR_DENSITY = 10.0
