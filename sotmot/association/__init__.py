"""Long-term association: what every solver shares, and the way to one by its name.

Every solver is a function ::

    solve(tracklets: Sequence[Tracklet], config: AssociationConfig) -> Association

that groups tracklets into trajectories, obeying the constraint function
:func:`sotmot.association.checks.check_pair` for every pair of tracklets it
joins directly. The solvers themselves live in the top-level ``solvers``
package, one module each, registered by their CLI name in
:data:`sotmot.plugins.SOLVERS`; this package reaches them only through that
table, importing a solver (and its heavy dependencies, e.g. OR-Tools) only when
it is asked for.

Modules: ``base`` (the solver's contract), ``rules`` (the rule table),
``checks`` (the vectorised checker and candidate pairs), ``merge`` (joining
tracklets), ``candidates`` (the association graph), ``objective`` (the costs
every solver is scored on), ``flow_network`` (the min-cost flow network).
"""

from __future__ import annotations

import importlib

from sotmot.association.base import Association, Link, Solver
from sotmot.errors import SolverError
from sotmot.plugins import SOLVERS


def get_solver(name: str) -> Solver:
    """The solver registered as ``name`` in :data:`sotmot.plugins.SOLVERS`.

    Raises
    ------
    SolverError
        For an unknown name; the message lists the valid names.
    """
    target = SOLVERS.get(name)
    if target is None:
        raise SolverError(f"unknown solver {name!r}; valid solvers: {', '.join(sorted(SOLVERS))}")
    module, func = target.split(":")
    solver: Solver = getattr(importlib.import_module(module), func)
    return solver


__all__ = ["SOLVERS", "Association", "Link", "Solver", "get_solver"]
