"""The house rules of ARCHITECTURE.md, checked: stages without import cycles, small modules,
bindings that mirror the Python stages, every drawable kind wired through every stage."""

from __future__ import annotations

import ast
from pathlib import Path

import cumuli as cu
from cumuli import registry

ROOT = Path(__file__).resolve().parents[2]
PACKAGE = ROOT / "python" / "cumuli"
STAGES = ("model", "light", "rendering", "anim", "io")


def _module_name(path: Path) -> str:
    parts = ("cumuli", *path.relative_to(PACKAGE).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _imports() -> dict[str, set[str]]:
    """Module → the cumuli modules it imports (anywhere in the file, functions included)."""
    modules = {_module_name(p): p for p in PACKAGE.rglob("*.py")}
    graph: dict[str, set[str]] = {}
    for name, path in modules.items():
        deps: set[str] = set()
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            module = node.module if isinstance(node, ast.ImportFrom) else None
            if module and module.startswith("cumuli"):
                deps.add(module)
                deps.update(f"{module}.{a.name}" for a in node.names)
            elif isinstance(node, ast.Import):
                deps.update(a.name for a in node.names if a.name.startswith("cumuli"))
        graph[name] = {d for d in deps if d in modules and d not in (name, "cumuli")}
    return graph


def test_no_import_cycles_between_modules() -> None:
    graph = {m: deps for m, deps in _imports().items() if m != "cumuli"}
    state: dict[str, int] = {}
    path: list[str] = []
    cycles: list[list[str]] = []

    def visit(m: str) -> None:
        state[m] = 1
        path.append(m)
        for d in sorted(graph.get(m, ())):
            if state.get(d) == 1:
                cycles.append([*path[path.index(d) :], d])
            elif d not in state and d in graph:
                visit(d)
        path.pop()
        state[m] = 2

    for m in sorted(graph):
        if m not in state:
            visit(m)
    assert cycles == []


def test_stages_depend_only_on_earlier_stages() -> None:
    # model → light → rendering → anim → kinds (the registrations, which see every stage); io,
    # gl (the GL backend), _util and the top-level modules serve all of them, so the serving
    # packages import no stage.
    order = {"model": 0, "light": 1, "rendering": 2, "anim": 3, "kinds": 4}
    serving = ("io", "gl", "_util")
    for module, deps in _imports().items():
        stage = module.split(".")[1] if module.count(".") >= 2 else None
        if stage not in order and stage not in serving:
            continue
        for d in deps:
            other = d.split(".")[1] if d.count(".") >= 2 else None
            if other in order:
                assert stage in order, f"{module} serves the stages but imports the stage {d}"
                assert order[other] <= order[stage], f"{module} imports the later stage {d}"


def test_modules_stay_small() -> None:
    sizes = {p.name: len(p.read_text(encoding="utf-8").splitlines()) for p in PACKAGE.rglob("*.py")}
    assert max(sizes.values()) <= 600, {k: v for k, v in sizes.items() if v > 600}


def test_bindings_mirror_the_python_stages() -> None:
    bindings = {p.stem for p in (ROOT / "cpp" / "bindings").glob("*.cpp")}
    assert {"noise", "model", "light", "rendering", "anim"} <= bindings
    assert bindings - {"noise", "model", "light", "rendering", "anim"} <= {"common", "module"}
    for stage in ("model", "light", "rendering", "anim"):
        assert (ROOT / "cpp" / "include" / "cumuli" / stage).is_dir()
        assert (ROOT / "cpp" / "src" / stage).is_dir()
        assert (PACKAGE / stage / "__init__.py").is_file()


def test_every_kind_is_wired_through_every_stage() -> None:
    for kind in registry.kinds():
        assert kind.model.kind == kind.name and callable(kind.light), kind.name
        assert isinstance(kind.gl_drawer, type) and callable(kind.cpu_drawer), kind.name
        for method in ("bounds", "layer_box", "to_dict", "from_dict"):
            assert callable(getattr(kind.model, method)), (kind.name, method)
        for module in kind.modules:  # its own modules exist
            assert (PACKAGE / (module.replace(".", "/") + ".py")).is_file(), (kind.name, module)
        assert (PACKAGE / "kinds" / f"{kind.modules[-1].split('.')[-1]}.py").is_file()
        if kind.medium is not None:  # takes part in the physical mode
            assert kind.physical_light is not None, kind.name
        assert (kind.cpu_split is None) == (kind.split_key is None), kind.name


#: ``isinstance`` tests on a concrete kind's class outside that kind's own modules allowed in
#: the whole package (stage code asks the registry instead).
MAX_FOREIGN_ISINSTANCE = 5


def foreign_isinstance(root: Path = PACKAGE) -> list[str]:
    """``module:line class`` of every ``isinstance(x, C)`` with ``C`` a registered kind's model
    class in a module that is not one of that kind's own (``Kind.modules``)."""
    owners: dict[str, set[str]] = {}
    for kind in registry.kinds():
        owners.setdefault(kind.model.__name__, set()).update(kind.modules)
    found = []
    for path in sorted(root.rglob("*.py")):
        module = ".".join(path.relative_to(root).with_suffix("").parts)
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if not (
                isinstance(node, ast.Call)
                and isinstance(node.func, ast.Name)
                and node.func.id == "isinstance"
                and len(node.args) == 2
            ):
                continue
            arg = node.args[1]
            names = arg.elts if isinstance(arg, ast.Tuple) else [arg]
            for n in names:
                name = n.id if isinstance(n, ast.Name) else getattr(n, "attr", None)
                if name in owners and module not in owners[name]:
                    found.append(f"{module}:{node.lineno} {name}")
    return found


def test_stage_code_asks_the_registry_not_the_class() -> None:
    found = foreign_isinstance()
    assert len(found) <= MAX_FOREIGN_ISINSTANCE, found


def test_the_foreign_isinstance_count_sees_an_offender(tmp_path: Path) -> None:
    # The check above can fail: a stage module testing a kind's class is counted, its own not.
    (tmp_path / "light").mkdir()
    code = "def f(d, Cloud):\n    return isinstance(d, (int, Cloud))\n"
    (tmp_path / "light" / "probe.py").write_text(code, encoding="utf-8")
    (tmp_path / "light" / "ndt.py").write_text(code, encoding="utf-8")
    assert foreign_isinstance(tmp_path) == ["light.probe:2 Cloud"]


def test_the_public_names_stay() -> None:
    # Every name cumuli exported before the house moved (tests may only change import lines).
    before = """AnimationFrame EndlessAnimation VolumeDatabase VolumeLighting VolumeRenderer
    blend_volumes crossfade_weights evolving_cloud_volumes render_volume similarity_matrix
    transition_matrix Camera Cloud ellipsoids_from_mesh fly_towards frames from_srgb8
    gaussian_cumulus light_grid LightStats load_cloud load_scene lsystem_cloud lsystem_expand
    lsystem_length merge mesh_cloud meshes metaball_cumulus Noise orbit prepare_light read_image
    render render_cpu render_frames Renderer RenderSettings Scene Sky Sun to_srgb8 write_image
    __version__""".split()
    missing = [n for n in before if n not in cu.__all__ or not hasattr(cu, n)]
    assert missing == []
