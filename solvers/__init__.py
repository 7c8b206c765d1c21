"""Long-term association solvers: one module each, registered by CLI name in :data:`sotmot.plugins.SOLVERS`.

``greedy`` (the paper's greedy merge), ``mincostflow`` (min-cost flow with
OR-Tools, and its two-stage variant), ``networkx_flow`` (the same flow with
networkx, for cross-checks), ``lifted`` (the lifted objective, exact per window
with CP-SAT). Each imports what it shares with the others from
:mod:`sotmot.association`; adding a solver is one module here plus one line in
the table. :func:`get_solver` is re-exported for convenience.
"""

from sotmot.association import SOLVERS, Association, Link, Solver, get_solver

__all__ = ["SOLVERS", "Association", "Link", "Solver", "get_solver"]
