"""The package's layering: each package imports only from the layers below it, and no module is in an import cycle.

The layers are the table :data:`LAYERS` (the same as ``docs/architecture.md``): a module may import the
packages of lower layers and the modules of its own package (in an order without cycles), never a package
of its own layer or of a higher one.

The import graph is built from the source with ``ast``, so it sees what running the code may not:
imports inside functions, ``importlib.import_module("encal.x")`` calls, and tables of module names
(``"encal.models.fourier"`` strings) that a module imports by name later.
"""

import ast
from tests._paths import SRC, TESTS

PACKAGE_ROOT = SRC / "encal"

#: encal's layers from the bottom up, each a name and its packages (``docs/architecture.md``, "The layers").
LAYERS = (
    ("foundation", ("encal._core", "encal._version", "encal.runtime")),
    ("numerics", ("encal.numerics",)),
    ("training and figures", ("encal.training", "encal.figures")),
    ("analysis of a profile", ("encal.analysis",)),
    ("calibration data", ("encal.data",)),
    ("models", ("encal.models",)),
    ("simulation, self-calibration, records", ("encal.simulate", "encal.selfcal", "encal.store")),
    ("deployment", ("encal.deploy",)),
    ("reports and fleets", ("encal.reports", "encal.fleet")),
    ("the paper", ("encal.paper",)),
    ("command line", ("encal.cli",)),
    ("entry points", ("encal", "encal.__main__")),
)

#: Folders of ``tests/`` that are no package of encal: the tests that cross the layers, and the harnesses that
#: run the firmwares' own code (``tests/data/`` is both the data package's tests and the model files they read).
TESTS_BESIDE_THE_TREE = ("system", "deploy/firmware_own")


def module_files(root):
    """Dotted module name -> source file, for every module of the package at ``root``."""
    modules = {}
    for path in root.rglob("*.py"):
        parts = list(path.relative_to(root.parent).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts = parts[:-1]
        modules[".".join(parts)] = path
    return modules


def _absolute(module, is_package, level, name):
    """The absolute name of ``from <level dots><name> import ...`` written in ``module``."""
    if level == 0:
        return name
    base = module.split(".")
    if not is_package:
        base = base[:-1]
    base = base[:len(base) - (level - 1)]
    return ".".join(base + ([name] if name else []))


def _imported_names(module, path):
    """Every module name ``module`` may import: statements anywhere, import_module calls, name tables."""
    is_package = path.name == "__init__.py"
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            yield from (alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            base = _absolute(module, is_package, node.level, node.module or "")
            yield base
            yield from (f"{base}.{alias.name}" for alias in node.names)
        elif isinstance(node, ast.Call) and getattr(node.func, "attr", getattr(node.func, "id", None)) \
                == "import_module" and node.args and isinstance(node.args[0], ast.Constant):
            yield node.args[0].value
        elif isinstance(node, ast.Constant) and isinstance(node.value, str):
            yield node.value


def import_graph(root):
    """Module -> the package's modules it imports (its own submodules and parent packages left out)."""
    modules = module_files(root)
    graph = {}
    for module, path in modules.items():
        targets = set()
        for name in _imported_names(module, path):
            if not isinstance(name, str) or not name.startswith(root.name):
                continue
            while name and name not in modules:  # `from encal.x import y` names y, a function of encal.x
                name = name.rpartition(".")[0]
            # A package importing its submodules, or a module its own package, is not a layering edge.
            if name and name != module and not module.startswith(name + ".") \
                    and not name.startswith(module + "."):
                targets.add(name)
        graph[module] = targets
    return graph


def import_cycles(graph):
    """The strongly connected components with more than one module (Tarjan), each sorted."""
    index, low, stack, on_stack, cycles = {}, {}, [], set(), []

    def visit(node):
        index[node] = low[node] = len(index)
        stack.append(node)
        on_stack.add(node)
        for target in graph[node]:
            if target not in index:
                visit(target)
                low[node] = min(low[node], low[target])
            elif target in on_stack:
                low[node] = min(low[node], index[target])
        if low[node] == index[node]:
            component = []
            while True:
                member = stack.pop()
                on_stack.discard(member)
                component.append(member)
                if member == node:
                    break
            if len(component) > 1:
                cycles.append(sorted(component))

    for node in sorted(graph):
        if node not in index:
            visit(node)
    return cycles


def package_of(module):
    """The top-level package (or module) of ``module``: ``encal.models`` for ``encal.models.fourier``."""
    return ".".join(module.split(".")[:2])


def layer_violations(graph, layers):
    """``(module, imported module, why)`` for every import that does not go down the layers."""
    layer_of = {package: index for index, (_, packages) in enumerate(layers) for package in packages}
    violations = []
    for module in sorted(graph):
        for target in sorted(graph[module]):
            own, other = package_of(module), package_of(target)
            if own == other:
                continue
            if own not in layer_of or other not in layer_of:
                violations.append((module, target, f"{own if own not in layer_of else other} is in no layer"))
            elif layer_of[other] == layer_of[own]:
                violations.append((module, target, f"same layer ({layers[layer_of[own]][0]})"))
            elif layer_of[other] > layer_of[own]:
                names = layers[layer_of[own]][0], layers[layer_of[other]][0]
                violations.append((module, target, "up from {} to {}".format(*names)))
    return violations


def test_the_graph_sees_deferred_and_by_name_imports(tmp_path):
    package = tmp_path / "pkg"
    (package / "sub").mkdir(parents=True)
    (package / "__init__.py").write_text("")
    (package / "sub" / "__init__.py").write_text("")
    (package / "a.py").write_text("def f():\n    from .sub import b\n")
    (package / "sub" / "b.py").write_text("import importlib\nimportlib.import_module('pkg.c')\n")
    (package / "c.py").write_text("TABLE = {'x': ('pkg.a', 'f')}\n")
    graph = import_graph(package)
    assert graph["pkg.a"] == {"pkg.sub", "pkg.sub.b"}  # importing pkg.sub.b runs pkg.sub first
    assert graph["pkg.sub.b"] == {"pkg.c"}
    assert graph["pkg.c"] == {"pkg.a"}
    assert import_cycles(graph) == [["pkg.a", "pkg.c", "pkg.sub.b"]]


def test_no_import_cycle_among_encal_modules():
    cycles = import_cycles(import_graph(PACKAGE_ROOT))
    assert cycles == [], "import cycles: " + "; ".join(" <-> ".join(cycle) for cycle in cycles)


def test_the_layer_check_sees_an_import_up_or_across(tmp_path):
    package = tmp_path / "pkg"
    for folder in ("low", "mid", "side", "top"):
        (package / folder).mkdir(parents=True)
        (package / folder / "__init__.py").write_text("")
    (package / "__init__.py").write_text("")
    (package / "low" / "a.py").write_text("def f():\n    from ..top import b\n")  # deferred, still up
    (package / "mid" / "c.py").write_text("from ..low import a\nfrom ..side import d\n")
    (package / "side" / "d.py").write_text("")
    (package / "top" / "b.py").write_text("from ..mid import c\nfrom ..stray import e\n")
    (package / "stray.py").write_text("")
    layers = (("low", ("pkg.low",)), ("mid", ("pkg.mid", "pkg.side")), ("top", ("pkg.top",)))
    assert layer_violations(import_graph(package), layers) == [
        ("pkg.low.a", "pkg.top", "up from low to top"),
        ("pkg.low.a", "pkg.top.b", "up from low to top"),
        ("pkg.mid.c", "pkg.side", "same layer (mid)"),
        ("pkg.mid.c", "pkg.side.d", "same layer (mid)"),
        ("pkg.top.b", "pkg.stray", "pkg.stray is in no layer"),
    ]


def test_every_package_of_encal_is_in_one_layer():
    packages = [package for _, members in LAYERS for package in members]
    assert len(packages) == len(set(packages))
    found = {package_of(module) for module in module_files(PACKAGE_ROOT)}
    assert sorted(found - set(packages)) == [], "a package in no layer: place it in LAYERS and docs/architecture.md"
    assert sorted(set(packages) - found) == [], "a package of LAYERS that is gone"


def test_each_package_imports_only_from_the_layers_below_it():
    violations = layer_violations(import_graph(PACKAGE_ROOT), LAYERS)
    assert violations == [], "imports that do not go down the layers (docs/architecture.md):\n" + "\n".join(
        f"{module} -> {target}: {why}" for module, target, why in violations)


def test_each_folder_of_tests_mirrors_a_package_of_encal():
    """A test's path names its layer: ``tests/<package>/`` holds the tests of ``src/encal/<package>/``."""
    packages = {path.parent.relative_to(PACKAGE_ROOT).as_posix() for path in PACKAGE_ROOT.rglob("__init__.py")}
    folders = {path.parent.relative_to(TESTS).as_posix() for path in TESTS.rglob("test_*.py")}
    assert sorted(folders - packages - set(TESTS_BESIDE_THE_TREE) - {"."}) == [], \
        "a folder of tests/ that mirrors no package of src/encal (docs/architecture.md, 'The tests')"
    # Test files of the same name in two folders (tests/cli/test_fit.py, ...) need each folder to be a package.
    assert sorted(folder for folder in folders if not (TESTS / folder / "__init__.py").is_file()) == []
