"""The pin deck: ten pins to the USBC specification, pin action by MuJoCo (the optional extra
``bowlrec[pins]``), the leave in bowlers' names, ten-pin scoring and spare targets.

Nothing here loads MuJoCo at import; :mod:`bowlrec.pins.engine` does when a pin simulation is
asked for. bowlrec never renders with MuJoCo, so importing this package sets ``MUJOCO_GL`` to
``disable`` unless it is set: MuJoCo then loads no OpenGL binding (its GLFW binding would probe
the library in a child process at import).

Lane frame as everywhere in bowlrec (x from the foul line toward the pins, y from the right
gutter toward the left, z up); pins are numbered as a right-hander sees them (pin 2 left of the
head pin, pin 3 right).
"""

import os

os.environ.setdefault("MUJOCO_GL", "disable")
