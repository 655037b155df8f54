"""Version constants: the package, the physics model and the bowlers' layer.

Every run's provenance and run ID carry them (:mod:`bowlrec.provenance`); this module imports
nothing, so any layer may read them.
"""

from __future__ import annotations

__all__ = ["BOWLER_LAYER_VERSION", "PHYSICS_VERSION", "PIN_MODEL_VERSION", "__version__"]

__version__ = "0.1.0"
#: version of the physics model and its numerics; part of every run's provenance and run ID. It
#: changes whenever results change beyond rounding (CHANGELOG.md says what each version changed).
PHYSICS_VERSION = "frohlich2004-ts54-7"
#: version of the bowlers' layer (spec sheet, layout and PAP, delivery -> physical scene); part
#: of every run's provenance. Version 2 places the PAP at +omega_hat for a right-hander, grip
#: facing the bowler at release; in runs stored with 1 or without the field the PAP is at the
#: other end of the axis, so their layout and side-weight labels describe the mirror-side ball.
#: Version 3 maps oil to the calibrated friction (docs/calibration.md) where 2 used the paper's
#: 0.04 / 0.20, and drills the sphere's part of each hole where 2 removed the whole cylinder
#: (:func:`bowlrec.provenance.bowler_layer_warning` says which applies to a stored run).
BOWLER_LAYER_VERSION = 3
#: version of the pin model (the deck, the pins' profile and mass properties, the contact model
#: and its calibration, the rest and standing rules: bowlrec.pins); part of the run ID of every
#: run with pin action (the engine's own version goes into provenance)
PIN_MODEL_VERSION = "usbc-mujoco-1"
