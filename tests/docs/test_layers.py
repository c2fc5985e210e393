"""The layering rule of docs/ARCHITECTURE.md: data -> models -> train / sim -> orchestration -> CLI. A module
imports only from its own layer or the layers below, train and sim never import each other, and the rooms of a
layer (its top-level modules and folders) import each other without a loop."""

import ast
from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[2] / "src" / "steerlab"

LAYERS = [
    ("base", ["errors", "locks", "video", "figures", "options", "control", "paths", "files", "processes", "cpu"]),
    ("data", ["data"]),
    ("models", ["models", "checkpoint", "runtime", "export", "pilot", "donkey"]),
    ("train / sim", ["train", "sim", "evaluate", "serve"]),
    ("orchestration", ["split_replay", "experiment", "dagger", "tune", "demo"]),
    ("cli", ["cli", "__main__"]),
]


def layer_of(module: str) -> int:
    """The layer of `steerlab.<module>` (a dotted path below the package)."""
    top = module.split(".")[0]
    for i, (_, names) in enumerate(LAYERS):
        if top in names:
            return i
    raise AssertionError(f"steerlab.{module} belongs to no layer: add it to LAYERS and to docs/ARCHITECTURE.md")


def imports(path: Path, package: str | None = None) -> set[str]:
    """Every steerlab module that a file imports (at the top or inside functions), relative imports resolved
    against its package: `package` (dotted below steerlab, "" for steerlab itself), by default the folder the file
    lies in below src/steerlab."""
    if package is None:
        package = ".".join(path.resolve().parent.relative_to(PACKAGE).parts)
    found = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom) and node.level:  # from . import x, from ..train.loop import f
            parts = package.split(".") if package else []
            base = parts[: len(parts) - node.level + 1]
            if node.module:
                found.add(".".join([*base, node.module]))
            else:
                found.update(".".join([*base, a.name]) for a in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module and node.module.startswith("steerlab"):
            found.add(node.module.removeprefix("steerlab").lstrip(".") or node.names[0].name)
        elif isinstance(node, ast.Import):
            found.update(a.name.removeprefix("steerlab.") for a in node.names if a.name.startswith("steerlab."))
    return found


def modules() -> dict[str, set[str]]:
    """Every module of the package (dotted, below steerlab) and what it imports."""
    out = {}
    for path in sorted(PACKAGE.rglob("*.py")):
        module = ".".join(path.relative_to(PACKAGE).with_suffix("").parts)
        if module != "__init__":
            out[module.removesuffix(".__init__")] = imports(path)
    return out


def loops(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected groups of more than one node (every import loop), by Tarjan's algorithm."""
    index, low, stack, on, found, counter = {}, {}, [], set(), [], [0]

    def visit(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in graph.get(v, ()):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            group = []
            while True:
                w = stack.pop()
                on.discard(w)
                group.append(w)
                if w == v:
                    break
            if len(group) > 1:
                found.append(sorted(group))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return found


def test_no_module_imports_a_higher_layer():
    wrong = []
    for module, deps in modules().items():
        for dep in deps:
            if layer_of(dep) > layer_of(module):
                wrong.append(f"{module} ({LAYERS[layer_of(module)][0]}) imports {dep} ({LAYERS[layer_of(dep)][0]})")
            if {module.split(".")[0], dep.split(".")[0]} == {"train", "sim"}:
                wrong.append(f"{module} imports {dep}: train and sim are side by side")
    assert not wrong, "\n".join(wrong)


def test_no_loop_between_the_rooms_of_a_layer():
    """Folders and top-level modules (the rooms) form no import loop: train -> evaluate -> train would be one."""
    rooms: dict[str, set[str]] = {}
    for module, deps in modules().items():
        room = module.split(".")[0]
        rooms.setdefault(room, set()).update(d.split(".")[0] for d in deps if d.split(".")[0] != room)
    assert loops(rooms) == []


def test_the_checks_see_a_violation(tmp_path):
    """The rules would catch a data module that imports the trainer, even inside a function, and a loop."""
    bad = tmp_path / "bad.py"
    bad.write_text("def f():\n    from steerlab.train.loop import train\n")
    assert imports(bad, "data") == {"train.loop"} and layer_of("train.loop") > layer_of("data.readers")
    # relative imports, as a module of data/ would write them
    bad.write_text("from ..train.loop import train\nfrom . import readers\nfrom .tub import read\n")
    assert imports(bad, "data") == {"train.loop", "data.readers", "data.tub"}
    assert loops({"train": {"evaluate"}, "evaluate": {"train", "data"}, "data": set()}) == [["evaluate", "train"]]


def test_recording_layouts_sit_below_the_dispatcher():
    """data/readers.py picks a layout's reader; no layout module imports it back (no cycle among the readers)."""
    back = [p.name for p in sorted((PACKAGE / "data").glob("*.py")) if p.name != "readers.py"
            and "data.readers" in imports(p)]
    assert not back, f"these data modules import data/readers.py: {back}"


# sim/ by world: the shared core, the generic replay (a recording seen as a world), the worlds side by side (each with
# its registry entry and replay flavour), and the registry of worlds on top; a room imports only from its own level
# and the levels below
SIM_LEVELS = [["core"], ["replay"], ["road", "track"], ["worlds"]]


def room_of(module: str) -> str:
    return module.split(".")[1]


def sim_level(module: str) -> int:
    room = room_of(module)
    return next(i for i, rooms in enumerate(SIM_LEVELS) if room in rooms)


def sim_violations(graph: dict[str, set[str]]) -> list[str]:
    """The imports between sim's rooms that run up, or from one world into another."""
    wrong = []
    for module, deps in graph.items():
        if not module.startswith("sim.") or module == "sim":
            continue
        for dep in deps:
            if not dep.startswith("sim.") or room_of(dep) == room_of(module):
                continue
            if sim_level(dep) > sim_level(module):
                wrong.append(f"{module} imports {dep}, a room above it")
            elif sim_level(dep) == sim_level(module):
                wrong.append(f"{module} imports {dep}: the worlds stand side by side")
    return wrong


def test_sim_rooms_import_down_and_the_worlds_not_each_other():
    wrong = sim_violations(modules())
    assert not wrong, "\n".join(wrong)
    assert sim_violations({"sim.track.world": {"sim.road.world"}, "sim.core.driving": {"sim.replay.run"},
                           "sim.replay.run": {"sim.core.driving", "sim.track.world"}}) == [
        "sim.track.world imports sim.road.world: the worlds stand side by side",
        "sim.core.driving imports sim.replay.run, a room above it",
        "sim.replay.run imports sim.track.world, a room above it"]
    assert {p.name for p in (PACKAGE / "sim").iterdir() if p.is_dir() and p.name != "__pycache__"} == \
        {room for rooms in SIM_LEVELS for room in rooms if room != "worlds"}


def test_every_world_is_a_folder_with_the_same_modules():
    """What a world provides, by its modules: another world is another folder with these (its entry in `entry.py`),
    and one line in the registry (sim/worlds.py; docs/architecture/worlds.md, "Adding a world")."""
    from steerlab.sim.worlds import WORLDS

    for name in WORLDS:
        have = {p.stem for p in (PACKAGE / "sim" / name).glob("*.py")}
        assert {"entry", "world", "run", "suite", "render", "expert", "plots"} <= have, (name, sorted(have))


def test_no_source_file_is_over_400_lines():
    long = {p.relative_to(PACKAGE).as_posix(): n for p in PACKAGE.rglob("*.py")
            if (n := len(p.read_text().splitlines())) > 400}
    assert not long, long
