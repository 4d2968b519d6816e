"""The package's house rules, read from its source: layers, no import cycles, no other module's privates.

Layers, lowest first (a module imports only from its own layer or below):

0 base        vibdyn.errors, vibdyn._check, vibdyn._deprecation, vibdyn._format, vibdyn.defaults, vibdyn.results
1 description vibdyn.description.*   what a user writes (scene, joints, elements, laws, loops, ...)
2 model       vibdyn.model.*         the compiled System, its workspaces, dynamics, forces, derivatives
3 time        vibdyn.simulation.*    simulate, its integrators, events and variational equations
4 analysis    vibdyn.analysis.*      equilibrium, linearize, modal, response, statespace, identify, ...
5 studies     vibdyn.studies.*       sweeps, example builders
6 io          vibdyn.io.*            scene files, robots (the description only: see the test below)
7 faces       vibdyn.faces.*         cli, plots, viewer
8 façade      vibdyn (its __init__)  the public names, loaded lazily

Analyses may call the time layer; the time layer never calls an analysis. The element kinds and joint
types of the description are plugins: each carries its compiled evaluation, built on the machinery the
model layer defines (vibdyn.model.points, vibdyn.model.groups): the one sanctioned import of the model by
the description besides the entry points.

The one sanctioned way up is an *entry point*: a method of a lower-layer class that forwards to a higher
layer on call (``Scene.build`` compiles, ``System.linearize`` runs the analysis, ``Modes.plot`` draws), the
import inside that method. Each is listed below by name; any other upward import, and any cycle among the
remaining imports, fails.
"""

import ast
import re
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "vibdyn"
LAYERS = {"errors": 0, "_check": 0, "_deprecation": 0, "_format": 0, "defaults": 0, "results": 0, "description": 1,
          "solvers": 2, "model": 2, "simulation": 3, "analysis": 4, "studies": 5, "io": 6, "faces": 7, "__main__": 8}
# the model layer's machinery that the description's plugins (element kinds) build on
PLUGIN_MACHINERY = {"vibdyn.model.points", "vibdyn.model.groups"}
PURE_DESCRIPTION = ("vibdyn.description.scene", "vibdyn.description.inertia", "vibdyn.description.laws",
                    "vibdyn.description.shapes", "vibdyn.description.loops",
                    "vibdyn.description.psd")
MAX_LINES = 700
SYSTEM_MAX_LINES = 350  # vibdyn/model/system.py

# (importing module, function or method) -> the higher-layer modules it may import on call
ENTRY_POINTS = {
    ("vibdyn.description.scene", "Scene.build"): {"vibdyn.model.system"},
    ("vibdyn.description.scene", "Scene.to_dict"): {"vibdyn.io.scenewrite"},
    ("vibdyn.description.scene", "Scene.save"): {"vibdyn.io.scenewrite"},
    ("vibdyn.model.system", "System.equilibrium"): {"vibdyn.analysis.equilibrium"},
    ("vibdyn.model.system", "System.equilibria"): {"vibdyn.analysis.equilibrium"},
    ("vibdyn.model.system", "System.steady_motion"): {"vibdyn.analysis.equilibrium"},
    ("vibdyn.model.system", "System.held"): {"vibdyn.analysis.equilibrium"},
    ("vibdyn.model.system", "System.operating_point"): {"vibdyn.analysis.equilibrium"},
    ("vibdyn.model.system", "System.linearize"): {"vibdyn.analysis.linearize"},
    # a reduced system (loops, drives, held speeds: vibdyn.model.reduction) is linearised, on call, in its
    # independent coordinates
    ("vibdyn.analysis.linearize", "linearize.reduced"): {"vibdyn.analysis.reduced"},
    # and the one equilibrium search gives a mechanism's result its loop forces (LoopEquilibrium builds on it)
    ("vibdyn.analysis.equilibrium", "search.found"): {"vibdyn.analysis.constrained"},
    ("vibdyn.model.system", "System.simulate"): {"vibdyn.simulation.simulate"},
    ("vibdyn.analysis.modal", "Modes.plot"): {"vibdyn.faces.viewer.pictures"},
    ("vibdyn.analysis.modal", "Modes.response_spectrum"): {"vibdyn.analysis.response.seismic"},
    ("vibdyn.description.record", "Record.pseudo_acceleration_spectrum"): {"vibdyn.analysis.response.record_spectrum"},
    ("vibdyn.analysis.response.record_spectrum", "RecordSpectrum.plot"): {"vibdyn.faces.spectrum_plots"},
    ("vibdyn.analysis.response.seismic", "SeismicResponse.plot"): {"vibdyn.faces.spectrum_plots"},
    # the linear model's methods are entry points to the analyses built on it (same layer, above it)
    **{("vibdyn.analysis.linearize", f"LinearModel.{m}"): {"vibdyn.analysis.response"}
       for m in ("free_response", "receptance", "harmonic_response", "base_response", "forced_response",
                 "random_response")},
    ("vibdyn.analysis.linearize", "LinearModel.appropriation"): {"vibdyn.analysis.response.appropriation"},
    ("vibdyn.analysis.linearize", "LinearModel.state_space"): {"vibdyn.analysis.statespace"},
    ("vibdyn.analysis.linearize", "LinearModel.modes"): {"vibdyn.analysis.modal"},
    ("vibdyn.analysis.linearize", "LinearModel.with_rayleigh"): {"vibdyn.analysis.modal"},
    ("vibdyn.analysis.campbell_diagram", "Campbell.plot"): {"vibdyn.faces.campbell_plot"},
    ("vibdyn.analysis.rotor_stability", "StabilityLimit.plot"): {"vibdyn.faces.campbell_plot"},
    ("vibdyn.analysis.rotor_stability", "CriticalSpeedMap.plot"): {"vibdyn.faces.campbell_plot"},
    ("vibdyn.analysis.unbalance", "UnbalanceResponse.plot"): {"vibdyn.faces.rotor_plots"},
    ("vibdyn.analysis.unbalance", "UnbalanceResponse.polar"): {"vibdyn.faces.rotor_plots"},
    # and the modes' to their sensitivities (which read the modes' own eigenproblem)
    ("vibdyn.analysis.modal", "Modes.sensitivity"): {"vibdyn.analysis.sensitivity"},
    ("vibdyn.description.psd", "PSD.plot"): {"vibdyn.faces.random_plots"},
    ("vibdyn.analysis.response.random", "RandomResponse.plot"): {"vibdyn.faces.random_plots"},
    ("vibdyn.results", "TimeResult.plot"): {"vibdyn.faces.plots"},
    ("vibdyn.analysis.nonlinear.harmonic_balance", "ForcedResponseCurve.plot"): {"vibdyn.faces.plots"},
    ("vibdyn.analysis.nonlinear.backbone", "Backbone.plot"): {"vibdyn.faces.plots"},
}


def module_name(path):
    parts = list(path.relative_to(PACKAGE.parent).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def layer(module):
    parts = module.split(".")
    return 8 if len(parts) == 1 else LAYERS[parts[1]]


MODULES = {module_name(p): p for p in PACKAGE.rglob("*.py")}


def imports():
    """(importer, imported module, enclosing function qualname or None) for every vibdyn import."""
    out = []
    for name, path in MODULES.items():
        package = name if path.name == "__init__.py" else name.rsplit(".", 1)[0]

        def visit(node, scope):
            for child in ast.iter_child_nodes(node):
                if isinstance(child, ast.If) and getattr(child.test, "id", None) == "TYPE_CHECKING":
                    continue  # for the type checker only: never imported at run time
                if isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
                    visit(child, f"{scope}.{child.name}" if scope else child.name)
                    continue
                targets = []
                if isinstance(child, ast.Import):
                    targets = [a.name for a in child.names if a.name.split(".")[0] == "vibdyn"]
                elif isinstance(child, ast.ImportFrom):
                    if child.level:
                        base = package.split(".")
                        base = ".".join(base[:len(base) - child.level + 1] + ([child.module] if child.module else []))
                    elif (child.module or "").split(".")[0] == "vibdyn":
                        base = child.module
                    else:
                        base = None
                    if base is not None:
                        targets = [f"{base}.{a.name}" if f"{base}.{a.name}" in MODULES else base for a in child.names]
                for target in targets:
                    out.append((name, target, scope if _in_function(scope) else None))
                visit(child, scope)

        visit(ast.parse(path.read_text()), "")
    return out


def _in_function(scope):
    return bool(scope) and not scope[0].isupper() or "." in scope


def test_every_module_is_in_a_layer():
    for name in MODULES:
        assert layer(name) is not None, name


def test_imports_go_down_except_named_entry_points():
    up = []
    for importer, target, scope in imports():
        if importer.startswith("vibdyn.description.elements") and target in PLUGIN_MACHINERY:
            continue
        if layer(target) > layer(importer) and target not in ENTRY_POINTS.get((importer, scope), ()):
            up.append(f"{importer} ({scope or 'module level'}) imports {target}")
    assert not up, "imports from a lower layer to a higher one:\n  " + "\n  ".join(sorted(set(up)))


def test_no_import_cycles():
    graph = {}
    for importer, target, scope in imports():
        if target in ENTRY_POINTS.get((importer, scope), ()) or target == importer:
            continue
        if target.startswith(importer + ".") and MODULES[importer].name == "__init__.py":
            continue  # a package's __init__ re-exporting its own modules
        graph.setdefault(importer, set()).add(target)
    cycles = _cycles(graph)
    assert not cycles, "import cycles:\n  " + "\n  ".join(" -> ".join(c) for c in cycles)


def _cycles(graph):
    """Strongly connected components with more than one module (Tarjan)."""
    index, low, stack, on, out = {}, {}, [], set(), []

    def strong(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in graph.get(v, ()):
            if w not in index:
                strong(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(sorted(comp))

    for v in list(graph):
        if v not in index:
            strong(v)
    return out


def test_the_checker_sees_a_violation():
    """The rules above can fail: a made-up upward import and a made-up cycle are caught."""
    assert layer("vibdyn.model.system") < layer("vibdyn.analysis.linearize")
    assert _cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}}) == [["a", "b", "c"]]
    assert _cycles({"a": {"b"}, "b": set()}) == []


PRIVATE = re.compile(r"\b(?!self\b|cls\b|super\(\))([a-z_][a-z0-9_]*)\._([a-z][a-z0-9_]*)\b")
# names of objects from outside the package whose underscore members are their own documented API
FOREIGN_OK = {"sys._getframe", "os._exit"}


@pytest.mark.parametrize("name", sorted(MODULES))
def test_no_use_of_another_modules_private_members(name):
    """``obj._member`` only on ``self``/``cls`` (a class's own privates) or on an object of the same module."""
    source = MODULES[name].read_text()
    own = {m for pair in re.findall(r"^\s*def\s+_(\w+)|self\._(\w+)\s*=", source, re.M) for m in pair if m}
    bad = []
    for lineno, line in enumerate(source.splitlines(), 1):
        code = line.split("#", 1)[0]
        for m in PRIVATE.finditer(code):
            if (m.group(2) in own or f"{m.group(1)}._{m.group(2)}" in FOREIGN_OK
                    or code.strip().startswith(("from", "import"))):
                continue
            bad.append(f"{name}:{lineno}: {m.group(0)}")
    assert not bad, "uses of another object's private members:\n  " + "\n  ".join(bad)


def private_imports(source):
    """Modules of other packages imported through a private part (``scipy.integrate._ivp``, ``from x import
    _y``)."""
    out = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom) and not node.level:
            names = [node.module] + [f"{node.module}.{a.name}" for a in node.names]
        else:
            continue
        out += [n for n in names if n.split(".")[0] != "vibdyn"
                and any(p.startswith("_") and not p.endswith("__") for p in n.split("."))]
    return out


@pytest.mark.parametrize("name", sorted(MODULES))
def test_no_import_of_another_packages_private_modules(name):
    """scipy's ``_ivp`` and the like are not API: vibdyn imports only public modules of other packages."""
    assert not private_imports(MODULES[name].read_text()), name


def test_the_private_import_checker_sees_one():
    assert private_imports("from scipy.integrate._ivp.rk import Dop853DenseOutput") == [
        "scipy.integrate._ivp.rk", "scipy.integrate._ivp.rk.Dop853DenseOutput"]
    assert private_imports("import scipy._lib") == ["scipy._lib"]
    assert private_imports("from scipy.integrate import Radau\nfrom . import _private\nfrom __future__ import "
                           "annotations") == []


def all_imports(path):
    """Every module a file imports, at module level or inside functions (lazy imports included), by name."""
    out = []
    package = module_name(path) if path.name == "__init__.py" else module_name(path).rsplit(".", 1)[0]
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            out += [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                out.append(".".join(base[:len(base) - node.level + 1] + ([node.module] if node.module else [])))
            else:
                out.append(node.module or "")
    return out


def test_the_time_layer_imports_no_analysis_study_or_face():
    """simulation never calls an analysis (lazy imports included): analyses may integrate, not the reverse."""
    bad = [(n, t) for n, p in MODULES.items() if n.startswith("vibdyn.simulation") for t in all_imports(p)
           if t.startswith(("vibdyn.analysis", "vibdyn.studies", "vibdyn.faces"))]
    assert not bad, bad


def test_pure_description_modules_import_neither_pinocchio_nor_model_nor_io():
    """Scene, inertia, laws, shapes and loops are plain data; Scene.build and Scene.save forward lazily."""
    lazy = {("vibdyn.description.scene", "vibdyn.model.system"), ("vibdyn.description.scene", "vibdyn.io.scenewrite")}
    bad = []
    for name in PURE_DESCRIPTION:
        for target, scope in [(t, s) for i, t, s in imports() if i == name]:
            if target.startswith(("vibdyn.model", "vibdyn.io")) and not ((name, target) in lazy and scope):
                bad.append((name, target))
        bad += [(name, t) for t in all_imports(MODULES[name]) if t.split(".")[0] == "pinocchio"]
    assert not bad, bad


def test_io_needs_the_description_only():
    bad = [(n, t) for n, p in MODULES.items() if n.startswith("vibdyn.io") for t in all_imports(p)
           if t.startswith(("vibdyn.model", "vibdyn.analysis"))]
    assert not bad, bad


def test_no_module_is_longer_than_700_lines():
    long = {n: len(p.read_text().splitlines()) for n, p in MODULES.items()}
    assert not {n: k for n, k in long.items() if k > MAX_LINES}


def test_the_system_is_thin():
    """System is the public face: its work lives in the modules it forwards to (issue 33)."""
    assert len(MODULES["vibdyn.model.system"].read_text().splitlines()) <= SYSTEM_MAX_LINES


def test_the_shared_force_machinery_is_defined_in_the_model_layer():
    """Kinematics, the point sets and the group bases live in the model; the description's element kinds
    build on them (and the model's dynamics no longer reaches into the description for its own machinery)."""
    import vibdyn.description.elements as elements
    import vibdyn.model.groups as groups
    import vibdyn.model.points as points

    for cls in (points.Kinematics, points.PointSet, points.ScatteredPoints, groups.ForceGroup, groups.TwoPoint):
        assert cls.__module__ in ("vibdyn.model.points", "vibdyn.model.groups"), cls
    assert elements.Kinematics is points.Kinematics and elements.ForceGroup is groups.ForceGroup
    assert "Kinematics" not in MODULES["vibdyn.description.elements.base"].read_text()
    assert not [t for t in all_imports(MODULES["vibdyn.model.dynamics"]) if t.startswith("vibdyn.description")]


def class_setattrs(source):
    """``setattr(C, ...)`` calls whose target is a class (a name defined as one in the module, or capitalised):
    methods belong in the class body, where readers and type checkers see them."""
    tree = ast.parse(source)
    classes = {n.name for n in ast.walk(tree) if isinstance(n, ast.ClassDef)}
    return [n.lineno for n in ast.walk(tree) if isinstance(n, ast.Call) and getattr(n.func, "id", None) == "setattr"
            and n.args and isinstance(n.args[0], ast.Name) and (n.args[0].id in classes or n.args[0].id[:1].isupper())]


@pytest.mark.parametrize("name", sorted(MODULES))
def test_no_methods_set_onto_classes(name):
    assert not class_setattrs(MODULES[name].read_text()), name


def test_the_setattr_checker_sees_one():
    assert class_setattrs("class A:\n    pass\nsetattr(A, 'f', len)") == [3]
    assert class_setattrs("setattr(obj, 'direction', 1)") == []


# Modules that may read a system's loops and drives themselves: the model (which compiles them into its one
# reduction, vibdyn.model.reduction) and the time layer's integrators (which step the loops' projection and
# the drives' laws). Faces may still draw loops. Every analysis, study and the rest of the time layer ask the
# reduction (system.reduction) instead.
REDUCTION_READERS = ("vibdyn.model", "vibdyn.simulation.integrators", "vibdyn.faces", "vibdyn.description",
                     "vibdyn.io")


# the reduction's answers to "what kind of scene is this" (issue 41 item 1): an analysis asks the reduction to act
# (impose, close, independent, chart, reference_acceleration, require, ...) instead of reading these
REDUCTION_FLAGS = {"curved", "looped", "time_laws", "is_identity", "held_names", "held_speeds", "driven_names",
                   "driven_units", "driven_q", "law_values"}
# ``kind`` is a common name (dtype.kind, Onset.kind), and so is ``has``: a flag only where read off a reduction (what a
# scene has is asked by what the analysis does: ``require`` / ``allows``)
REDUCTION_NAMES = {"reduction", "R"}
# modules that still read a flag, each with what remains to be done (issue 41 item 1, in progress): empty at the end
FLAG_READERS_LEFT: dict[str, str] = {}


def reads_of_loops_or_drives(source):
    """Lines that read an attribute ``constraints``, ``drives`` or ``has_loops`` (``x.drives``, ``getattr(x,
    "drives", ...)``), or one of the reduction's flags (:data:`REDUCTION_FLAGS`, ``R.kind``)."""
    tree = ast.parse(source)
    names = {"constraints", "drives", "compiled_drives", "compiled_loops", "has_loops"} | REDUCTION_FLAGS

    def receiver(n):
        v = n.value
        return v.id if isinstance(v, ast.Name) else v.attr if isinstance(v, ast.Attribute) else None

    return sorted({n.lineno for n in ast.walk(tree)
                   if (isinstance(n, ast.Attribute) and (n.attr in names
                                                         or n.attr in ("kind", "has")
                                                         and receiver(n) in REDUCTION_NAMES))
                   or (isinstance(n, ast.Call) and getattr(n.func, "id", None) in ("getattr", "hasattr")
                       and len(n.args) > 1 and isinstance(n.args[1], ast.Constant) and n.args[1].value in names)})


@pytest.mark.parametrize("name", sorted(n for n in MODULES if not n.startswith(REDUCTION_READERS)))
def test_analyses_ask_the_reduction_not_the_loops_or_drives(name):
    reads = reads_of_loops_or_drives(MODULES[name].read_text())
    if name in FLAG_READERS_LEFT:
        assert reads, f"{name} reads no flag any more: take it off FLAG_READERS_LEFT"
        pytest.xfail(FLAG_READERS_LEFT[name])
    assert not reads, name


def forwarding_classes(source):
    """Classes that define ``__getattr__`` (forwarding every attribute they lack to another object)."""
    return [n.name for n in ast.walk(ast.parse(source)) if isinstance(n, ast.ClassDef)
            and any(isinstance(f, ast.FunctionDef) and f.name == "__getattr__" for f in n.body)]


@pytest.mark.parametrize("name", sorted(n for n in MODULES if n.startswith(("vibdyn.analysis", "vibdyn.studies"))))
def test_no_analysis_class_forwards_by_getattr(name):
    assert not forwarding_classes(MODULES[name].read_text()), name


def test_the_reduction_checkers_see_one():
    assert reads_of_loops_or_drives("a = system.drives\nb = getattr(s, 'constraints', None)\nc = s.reduction") == [1, 2]
    # the reduction's flags, by every spelling, and its kind (not any other object's)
    source = ("if system.reduction.curved:\n    pass\nx = R.time_laws or R.is_identity\ny = R.held_names\n"
              "z = reduction.held_speeds\nk = system.reduction.kind\nd = a.dtype.kind\nw = R.driven_names\n"
              "u = hasattr(R, 'curved')\nR.impose(q, v, t)\nR.require('backbones')\nh = not system.reduction.has()\n"
              "g = R.allows('backbones')")
    assert reads_of_loops_or_drives(source) == [1, 3, 4, 5, 6, 8, 9, 12]
    assert forwarding_classes("class V:\n    def __getattr__(self, n):\n        return 1\n") == ["V"]


def test_the_solver_kit_stays_small():
    """One place per setting: continuation takes at most 8 parameters (its stepping in one Arclength), and the
    Hungarian assignment is called only by the one tracker (vibdyn.solvers.tracking)."""
    import inspect

    from vibdyn.solvers.continuation import continuation

    assert len(inspect.signature(continuation).parameters) <= 8
    callers = [n for n, p in MODULES.items() if "linear_sum_assignment" in p.read_text()]
    assert callers == ["vibdyn.solvers.tracking"], callers


def calls_of_simulate(source):
    """Lines that import the public ``simulate`` (the function or its module) or call a name ``simulate``."""
    tree = ast.parse(source)
    return sorted({n.lineno for n in ast.walk(tree)
                   if (isinstance(n, ast.ImportFrom) and n.module and n.module.endswith("simulation.simulate"))
                   or (isinstance(n, ast.ImportFrom) and n.module and n.module.endswith("simulation")
                       and any(a.name == "simulate" for a in n.names))
                   or (isinstance(n, ast.Call) and getattr(n.func, "id", None) == "simulate")})


@pytest.mark.parametrize("name", sorted(n for n in MODULES if n.startswith(("vibdyn.analysis", "vibdyn.studies"))))
def test_analyses_integrate_through_the_flow_not_simulate(name):
    """simulate is the users' driver (checks and energies at every output); analyses integrate through Flow."""
    assert not calls_of_simulate(MODULES[name].read_text()), name


def test_the_simulate_checker_sees_one():
    assert calls_of_simulate("from ...simulation.simulate import SimulationError\nx = simulate(s, 1.0)") == [1, 2]
    assert calls_of_simulate("from ..simulation import simulate\nflow(q, v, 0, 1)") == [1]
