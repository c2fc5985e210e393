"""The layering rule of docs/ARCHITECTURE.md: data -> models -> train / sim -> orchestration -> CLI. A module
imports only from its own layer or the layers below, and train and sim never import each other."""

import ast
from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[1] / "src" / "steerlab"

LAYERS = [
    ("base", ["errors", "locks", "video", "figures"]),
    ("data", ["data"]),
    ("models", ["models", "checkpoint", "export", "pilot", "donkey"]),
    ("train / sim", ["train", "sim", "evaluate", "serve"]),
    ("orchestration", ["experiment", "dagger", "tune", "demo"]),
    ("cli", ["cli", "__main__"]),
]


def layer_of(module: str) -> int:
    """The layer of `steerlab.<module>` (a dotted path below the package)."""
    top = module.split(".")[0]
    for i, (_, names) in enumerate(LAYERS):
        if top in names:
            return i
    raise AssertionError(f"steerlab.{module} belongs to no layer: add it to LAYERS and to docs/ARCHITECTURE.md")


def imports(path: Path) -> set[str]:
    """Every steerlab module that a file imports (at the top or inside functions)."""
    found = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom) and node.module and node.module.startswith("steerlab"):
            found.add(node.module.removeprefix("steerlab").lstrip(".") or node.names[0].name)
        elif isinstance(node, ast.Import):
            found.update(a.name.removeprefix("steerlab.") for a in node.names if a.name.startswith("steerlab."))
    return found


def test_no_module_imports_a_higher_layer():
    wrong = []
    for path in sorted(PACKAGE.rglob("*.py")):
        module = ".".join(path.relative_to(PACKAGE).with_suffix("").parts)
        if module == "__init__":
            continue
        for dep in imports(path):
            if layer_of(dep) > layer_of(module):
                wrong.append(f"{module} ({LAYERS[layer_of(module)][0]}) imports {dep} ({LAYERS[layer_of(dep)][0]})")
            if {module.split(".")[0], dep.split(".")[0]} == {"train", "sim"}:
                wrong.append(f"{module} imports {dep}: train and sim are side by side")
    assert not wrong, "\n".join(wrong)


def test_the_check_sees_a_violation(tmp_path):
    """The rule would catch a data module that imports the trainer, even inside a function."""
    bad = tmp_path / "bad.py"
    bad.write_text("def f():\n    from steerlab.train.loop import train\n")
    assert imports(bad) == {"train.loop"} and layer_of("train.loop") > layer_of("data.readers")


def test_recording_layouts_sit_below_the_dispatcher():
    """data/readers.py picks a layout's reader; no layout module imports it back (no cycle among the readers)."""
    back = [p.name for p in sorted((PACKAGE / "data").glob("*.py")) if p.name != "readers.py"
            and "data.readers" in imports(p)]
    assert not back, f"these data modules import data/readers.py: {back}"
