"""The package's layout: each module on a floor, imports only downwards or sideways, no cycle, and the core
reaching a solver only through its name table (``sotmot.plugins``)."""

import ast
from pathlib import Path

import networkx as nx

ROOT = Path(__file__).resolve().parents[1]

#: Floor of each module (a prefix names a package and everything in it); a module imports only its own floor or
#: lower ones. A new module needs a line here: where it sits is a decision, not an accident.
FLOORS = {
    "sotmot.errors": 0, "sotmot.types": 0, "sotmot.plugins": 0, "sotmot.boxes": 0, "sotmot.progress": 0,
    "sotmot.hashing": 0, "sotmot.versions": 0,
    "sotmot": 0,  # the package's __init__ (its public names are imported lazily from their own modules)
    "sotmot.config": 1, "sotmot.models": 1,
    "sotmot.io": 2, "sotmot.scoring": 2,
    "sotmot.appearance": 3, "sotmot.detection": 3, "sotmot.postprocess": 3, "sotmot.motion": 3,
    "sotmot.confidence": 4, "sotmot.provenance": 4, "sotmot.passes": 4, "sotmot.sot": 4, "sotmot.tracklets": 4,
    "sotmot.plan": 4,
    "sotmot.workers": 4,
    "sotmot.preprocess": 5, "sotmot.confirm": 5, "sotmot.association": 5,
    "sotmot.solvers": 6,  # the solvers/ folder of the source tree, installed as sotmot.solvers
    "sotmot.pipeline": 7,
    "sotmot.runs": 8, "sotmot.windows": 8, "sotmot.stepping": 8, "sotmot.peers": 8, "sotmot.train": 8,
    "sotmot.benchmarks": 8,
    "sotmot.inspect": 9, "sotmot.fitting": 9, "sotmot.api": 9, "sotmot.live": 9,
    "sotmot.cli": 10, "sotmot.__main__": 10,
}


def modules() -> dict[str, Path]:
    found = {}
    for package, name in (("sotmot", "sotmot"), ("solvers", "sotmot.solvers")):  # pyproject.toml's package-dir
        for path in (ROOT / package).rglob("*.py"):
            module = ".".join((name, *path.relative_to(ROOT / package).with_suffix("").parts))
            found[module.removesuffix(".__init__")] = path
    return found


def import_graph() -> nx.DiGraph:
    """Every import between the project's modules, at module level or inside functions."""
    mods = modules()
    graph = nx.DiGraph()
    graph.add_nodes_from(mods)
    for name, path in mods.items():
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
                targets = [node.module] + [f"{node.module}.{alias.name}" for alias in node.names]
            elif isinstance(node, ast.Import):
                targets = [alias.name for alias in node.names]
            else:
                continue
            graph.add_edges_from((name, t) for t in targets if t in mods and t != name)
    return graph


def floor(module: str) -> int:
    best = max((p for p in FLOORS if module == p or module.startswith(p + ".")), key=len, default=None)
    assert best is not None, f"{module} has no floor in FLOORS"
    return FLOORS[best]


def test_every_import_goes_down_or_sideways():
    # a package re-exporting its own modules' names (sotmot.track from sotmot.api) is not an import upward
    upward = [(a, b) for a, b in import_graph().edges if floor(b) > floor(a) and not b.startswith(a + ".")]
    assert not upward, f"imports from a lower floor to a higher one: {upward}"


def test_no_import_cycle():
    graph = import_graph()
    # a package's __init__ and its own modules may refer to each other (it re-exports them); across modules, no
    for a, b in list(graph.edges):
        if b.startswith(a + ".") or a.startswith(b + "."):
            graph.remove_edge(a, b)
    cycles = list(nx.simple_cycles(graph))
    assert not cycles, f"import cycles: {cycles}"


def test_the_core_reaches_a_solver_only_through_the_name_table():
    graph = import_graph()
    def solver(module: str) -> bool:
        return module == "sotmot.solvers" or module.startswith("sotmot.solvers.")

    reached = [(a, b) for a, b in graph.edges if not solver(a) and solver(b)]
    assert not reached, f"the core imports a solver module directly: {reached}"
    from sotmot.plugins import SOLVERS

    assert all(target.startswith("sotmot.solvers.") for target in SOLVERS.values())


def test_the_floor_check_sees_an_upward_import():
    """The check can fail: a low module that imports the pipeline is caught."""
    graph = import_graph()
    graph.add_edge("sotmot.boxes", "sotmot.pipeline")
    assert [(a, b) for a, b in graph.edges if floor(b) > floor(a)] == [("sotmot.boxes", "sotmot.pipeline")]
