"""Long-term association solvers: one signature, one table.

Every solver is a function ::

    solve(tracklets: Sequence[Tracklet], config: AssociationConfig) -> Association

that groups tracklets into trajectories, obeying the constraint function
:func:`sotmot.constraints.check_pair` for every pair of tracklets it joins
directly. Solvers are registered in :data:`SOLVERS` by their CLI name and
imported only when asked for, so optional heavy dependencies (OR-Tools) load
only for the solver that needs them.
"""

from __future__ import annotations

import importlib
from typing import Callable

from solvers.base import Association, Link, Solver
from sotmot.errors import SolverError
from sotmot.plugins import SOLVERS

def get_solver(name: str) -> Solver:
    """The solver registered as ``name``.

    Raises
    ------
    SolverError
        For an unknown name; the message lists the valid names.
    """
    target = SOLVERS.get(name)
    if target is None:
        raise SolverError(f"unknown solver {name!r}; valid solvers: {', '.join(sorted(SOLVERS))}")
    module, func = target.split(":")
    solver: Callable = getattr(importlib.import_module(module), func)
    return solver


__all__ = ["SOLVERS", "Association", "Link", "Solver", "get_solver"]
