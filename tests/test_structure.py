"""The shape of the house: the core never imports training or the Blender layer, no package imports in
a cycle, the CLI's import loads no training code, and the extension zip carries no developer tools."""
import ast
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("panolight_core", "training", "blender_addon")


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _modules() -> dict:
    return {_module_name(p): p for pkg in PACKAGES for p in (ROOT / pkg).rglob("*.py")}


def _imports(name: str, path: Path, modules: dict) -> set:
    """Every module ``name`` imports anywhere in its file (module level or inside functions), resolved."""
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    found = set()
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            found.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")[:len(package.split(".")) - node.level + 1]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module
            subs = [f"{target}.{a.name}" for a in node.names if f"{target}.{a.name}" in modules]
            found.update(subs)
            if len(subs) < len(node.names) and node.module:  # names from a module, not submodules
                found.add(target)
    return found


def test_the_core_never_imports_training_or_the_blender_layer():
    modules = _modules()
    bad = {(name, imp) for name, path in modules.items() if name.startswith("panolight_core")
           for imp in _imports(name, path, modules) if imp.split(".")[0] in ("training", "blender_addon", "bpy")}
    assert not bad, sorted(bad)


def test_no_import_cycle_anywhere():
    modules = _modules()
    graph = {name: {i for i in _imports(name, path, modules) if i in modules and i != name}
             for name, path in modules.items()}
    state, stack, cycles = {}, [], []

    def visit(node):
        state[node] = "open"
        stack.append(node)
        for nxt in graph[node]:
            if state.get(nxt) == "open":
                cycles.append(stack[stack.index(nxt):] + [nxt])
            elif nxt not in state:
                visit(nxt)
        stack.pop()
        state[node] = "done"

    for node in sorted(graph):
        if node not in state:
            visit(node)
    assert not cycles, "\n".join(" -> ".join(c) for c in cycles)


def test_importing_the_cli_loads_no_training_module():
    code = "import sys, panolight_core.apps.cli; print(sorted(m for m in sys.modules if m.split('.')[0] == 'training'))"
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT, timeout=120)
    assert r.returncode == 0 and r.stdout.strip() == "[]", r.stdout + r.stderr


def test_the_extension_zip_holds_the_estimation_core_and_no_developer_tools(tmp_path):
    r = subprocess.run([sys.executable, str(ROOT / "scripts" / "build_extension.py"), "-o", str(tmp_path)],
                       capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    zpath, = tmp_path.glob("panolight-*.zip")
    names = zipfile.ZipFile(zpath).namelist()
    core = [n for n in names if n.startswith("panolight_core/")]
    assert "blender_manifest.toml" in names and "operators.py" in names and "panolight_core/sh/basis.py" in core
    assert "panolight_core/models/sources.safetensors" in core
    assert "panolight_core/models/sources_hdr.safetensors" in core  # what restores an HDR that clips its sun
    tools = [n for n in core if n.startswith(("panolight_core/apps/", "panolight_core/data.py"))
             or n.endswith(("cli.py", "evaluation.py", "extension.py", "__main__.py"))]
    assert not tools, tools
    assert not any(n.startswith(("training/", "tests/", "scripts/")) for n in names)
    # every bundled module imports from inside the bundle (relative imports only, no installed copy)
    bundle = tmp_path / "bundle"
    zipfile.ZipFile(zpath).extractall(bundle / "addon")
    (bundle / "addon" / "__init__.py").write_text("")  # stands in for the add-on (which needs bpy)
    mods = [".".join(Path(n).with_suffix("").parts).removesuffix(".__init__") for n in core if n.endswith(".py")]
    code = ("import importlib, sys\n"
            f"for m in {mods!r}: importlib.import_module('addon.' + m)\n"
            "print(sorted(m for m in sys.modules if m.startswith('panolight_core')))\n")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=bundle, timeout=120)
    assert r.returncode == 0 and r.stdout.strip() == "[]", r.stdout + r.stderr


@pytest.mark.parametrize("package", ["training", "blender_addon"])
def test_the_checkout_folders_are_not_installed_as_top_level_packages(package):
    import tomllib

    find = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]["packages"]["find"]
    assert all(not pattern.startswith(package) for pattern in find["include"])


def test_training_is_grouped_and_no_core_module_grows_past_450_lines():
    top = sorted(p.name for p in (ROOT / "training").glob("*.py"))
    assert len(top) <= 6, top  # the rest lives in subpackages by what it is (docs/development.md)
    long = {str(p.relative_to(ROOT)): n for p in (ROOT / "panolight_core").rglob("*.py")
            if (n := len(p.read_text(encoding="utf-8").splitlines())) > 450}
    assert not long, long


def test_the_core_tests_need_no_training_code():
    """tests/panolight_core tests the core alone: its fixtures come from the core (e.g. ``synthetic``); the
    parity with the training side's torch networks is tests/training's."""
    modules = _modules()
    bad = {str(p.relative_to(ROOT)) for p in (ROOT / "tests" / "panolight_core").rglob("*.py")
           for imp in _imports("tests.x", p, modules) if imp.split(".")[0] == "training"}
    assert not bad, sorted(bad)


def test_every_dependency_the_setup_installs_is_pinned_in_the_constraints():
    """scripts/setup.sh installs with -c scripts/constraints.txt so the shipped trees are reproducible: a new
    dependency (or extra) must be pinned there too, at the version in this venv (torch: setup.sh pins it)."""
    import re
    import tomllib
    from importlib.metadata import version

    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    specs = list(project["dependencies"]) + [d for deps in project["optional-dependencies"].values() for d in deps]

    def norm(name):
        return re.sub(r"[-_.]+", "-", name).lower()

    pins = {}
    for line in (ROOT / "scripts" / "constraints.txt").read_text().splitlines():
        if line.strip() and not line.startswith("#"):
            name, _, ver = line.partition("==")
            pins[norm(name)] = ver.strip()
    wanted = {norm(re.split(r"[<>=!~;\[ ]", s, maxsplit=1)[0]) for s in specs} - {"torch"}
    assert not wanted - set(pins), f"scripts/constraints.txt pins no version of {sorted(wanted - set(pins))}"
    if Path(sys.prefix).resolve() == (ROOT / ".venv").resolve():  # the venv setup.sh made holds exactly those
        stale = {n: (pins[n], version(n)) for n in wanted if version(n) != pins[n]}
        assert not stale, f"installed versions differ from scripts/constraints.txt: {stale}"


# The core's layers, low to high (docs/development.md): a module imports its own layer and those below, never
# one above, at module level or inside a function (where a tie running back up would hide).
CORE_LAYERS = (
    ("panolight_core.errors", "panolight_core.threads", "panolight_core._backend", "panolight_core.packed",
     "panolight_core.harm"),
    ("panolight_core.sh",),
    ("panolight_core.camera",),
    ("panolight_core.io",),
    ("panolight_core.estimators.highlights", "panolight_core.estimators.sky", "panolight_core.estimators.sun_search"),
    ("panolight_core.estimators.sources",),
    ("panolight_core.estimators.nn",),
    ("panolight_core.estimators.keylight",),
    ("panolight_core.estimators",),
    ("panolight_core.lighting", "panolight_core.metrics", "panolight_core.synthetic"),
    ("panolight_core.pipeline",),
    ("panolight_core.data", "panolight_core.apps", "panolight_core.__main__"),
    ("panolight_core",),
)


def _layer(name: str) -> int:
    """The layer of a core module: that of the longest CORE_LAYERS prefix naming it."""
    found = [(len(p), r) for r, prefixes in enumerate(CORE_LAYERS) for p in prefixes
             if name == p or name.startswith(p + ".")]
    return max(found)[1]


def test_no_core_import_runs_back_up_a_layer():
    modules = _modules()
    up = sorted(f"{name} -> {imp}" for name, path in modules.items() if name.startswith("panolight_core")
                for imp in _imports(name, path, modules)
                if imp in modules and imp.startswith("panolight_core") and _layer(imp) > _layer(name))
    assert not up, "\n".join(up)


def test_the_lighting_model_never_imports_the_estimators():
    """The lighting model (lights, SH order, relighting) stands on its own: the key light's notes live with the key
    light (estimators/keylight), and the equirect grid's connected components in sh.blobs."""
    modules = _modules()
    found = sorted(f"{name} -> {imp}" for name, path in modules.items() if name.startswith("panolight_core.lighting")
                   for imp in _imports(name, path, modules) if imp.startswith("panolight_core.estimators"))
    assert not found, "\n".join(found)


def test_no_core_function_takes_more_than_8_parameters():
    """Shipped signatures hold what ships: a study's knobs live in training (its variants, KeyLightParams)."""
    many = []
    for path in (ROOT / "panolight_core").rglob("*.py"):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                a = node.args
                names = [x.arg for x in a.posonlyargs + a.args + a.kwonlyargs]
                n = len(names) + bool(a.vararg) + bool(a.kwarg) - (names[:1] in (["self"], ["cls"]))
                if n > 8:
                    many.append(f"{path.relative_to(ROOT)}:{node.lineno} {node.name} ({n})")
    assert not many, many


def test_no_two_way_folder_tie_in_training():
    """training/'s folders (subpackages, and the top level) depend one way: no folder imports a folder that
    imports it back (the shared pieces live in training/common/)."""
    modules = _modules()

    def folder(name):
        return name if modules[name].name == "__init__.py" else name.rpartition(".")[0]

    edges = {(folder(name), folder(imp)) for name, path in modules.items() if name.startswith("training")
             for imp in _imports(name, path, modules) if imp in modules and imp.startswith("training")}
    two_way = sorted(f"{a} <-> {b}" for a, b in edges if a < b and (b, a) in edges)
    assert not two_way, two_way


def test_the_test_command_runs_the_linter_first():
    script = (ROOT / "scripts" / "test.sh").read_text()
    assert script.index("bin/ruff\" check") < script.index("-m pytest")
    import tomllib

    lint = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["ruff"]["lint"]
    assert {"F", "I", "B"} <= set(lint["select"])


def test_the_add_on_imports_the_core_by_name_and_bundles_what_it_imports():
    """blender_addon/core.py imports each core module the add-on uses with a plain import an IDE follows (the same in
    its bundled and checkout branches), and CORE_MODULES, which the extension build reads, names exactly those."""
    tree = ast.parse((ROOT / "blender_addon" / "core.py").read_text())
    branch = next(node for node in ast.walk(tree) if isinstance(node, ast.If))
    found = []
    for body, prefix in ((branch.body, ".panolight_core"), (branch.orelse, "panolight_core")):
        mods = set()
        for node in body:
            if isinstance(node, ast.ImportFrom) and node.module:  # not "from . import panolight_core as core"
                base = ("." * node.level + node.module)
                assert base.startswith(prefix), base
                sub = base[len(prefix):].lstrip(".")
                mods |= {f"{sub}.{a.name}".lstrip(".") for a in node.names}
        found.append(mods)
    assert found[0] == found[1]
    declared = next(ast.literal_eval(node.value) for node in tree.body if isinstance(node, ast.Assign)
                    and any(getattr(t, "id", None) == "CORE_MODULES" for t in node.targets))
    assert set(declared) == found[1]
    addon = {p.name: p.read_text() for p in (ROOT / "blender_addon").glob("*.py") if p.name not in ("core.py", "batch.py")}
    assert not [name for name, text in addon.items() if "core.io." in text or "core.pipeline." in text], \
        "the add-on's modules use the names core.py imports, not attribute chains"
