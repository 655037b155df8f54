"""Work-precision benchmark of bowlrec against independent integrations of the same equations.

* :mod:`bowlrec.testing.scenes`: the scenes (Table III as written, fixed-seed random
  deliveries), shared with the tests;
* :mod:`benchmarks.methods`: ``bowlrec_solve``, ``scipy_solve`` (solve_ivp segment by segment with
  terminal events) and ``paper_scheme`` (fixed-step RK4 with the paper's 1 cm/s rule, from
  :mod:`bowlrec.testing.rk4`, shared with the tests);
* :mod:`benchmarks.check_methods`: agreement of the methods on Table III at tight settings
  (``python -m benchmarks.check_methods`` from the repository root).
"""
