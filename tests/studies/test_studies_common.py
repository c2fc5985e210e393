"""studies/ and benchmarks/ as packages: what the studies share (the package studies/common/), and the rule that keeps the
scripts apart: no script edits sys.path, a study imports steerlab and `studies.common` (and its own private modules,
`studies._NAME`), never another study nor the tests, and a timing imports no study and no test either."""

import ast
from pathlib import Path

import pytest

from studies.common import truth as common
from studies.common import ROOT

TESTS = {p.stem for p in (ROOT / "tests").rglob("*.py")} | {"tests"}  # and every test_*, wherever it is


def _scripts(package: str) -> list[Path]:
    return sorted((ROOT / package).glob("*.py"))


def _imports(path: Path) -> list[str]:
    """Every module `path` imports (at the top or inside functions), `from X import a, b` as X.a and X.b, relative
    imports resolved against its package."""
    package = path.parent.name
    found = []
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            found += [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            module = ".".join(filter(None, [package if node.level else "", node.module or ""]))
            found += [f"{module}.{a.name}" for a in node.names]
    return found


def _edits_sys_path(path: Path) -> list[int]:
    """The lines of `path` that touch sys.path (`sys.path.insert`, `sys.path = ...`, also in code run by `-c`)."""
    lines = []
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Attribute) and node.attr == "path" and getattr(node.value, "id", None) == "sys":
            lines.append(node.lineno)
        elif isinstance(node, ast.Constant) and isinstance(node.value, str) and "sys.path" in node.value:
            lines.append(node.lineno)
    return sorted(lines)


def _wrong_imports(path: Path) -> list[str]:
    """What a script of studies/ or benchmarks/ imports that it may not: a test or a module of tests/ (through the
    package or as a top-level name), another study (through the package or as a top-level name, as a script that
    puts studies/ on sys.path would)."""
    studies = {p.stem for p in _scripts("studies")}
    own = {f"studies.{path.stem}"}
    wrong = []
    for module in _imports(path):
        top, _, rest = module.partition(".")
        if top in TESTS or top.startswith("test_") or (top in studies and top != "studies"):
            wrong.append(module)
        elif top == "studies" and rest:
            name = rest.split(".")[0]
            if name != "common" and not name.startswith("_") and f"studies.{name}" not in own:
                wrong.append(module)
    return wrong


def test_no_script_edits_sys_path_and_no_study_imports_a_test_or_another_study():
    scripts = _scripts("studies") + _scripts("benchmarks")
    assert len(scripts) > 25 and (ROOT / "studies" / "__init__.py").exists() and (ROOT / "benchmarks" / "__init__.py")
    edits = {str(p.relative_to(ROOT)): lines for p in scripts if (lines := _edits_sys_path(p))}
    assert edits == {}, f"these scripts edit sys.path (run them as python -m PACKAGE.NAME instead): {edits}"
    wrong = {str(p.relative_to(ROOT)): w for p in scripts if (w := _wrong_imports(p))}
    assert wrong == {}, f"a script imports a test or another study (share through studies/common/): {wrong}"


def test_the_rule_sees_each_way_of_breaking_it(tmp_path):
    """The checks above on scripts that break the rule in each way they can (hand-written, the lines known)."""
    study = tmp_path / "studies" / "x.py"
    study.parent.mkdir()
    study.write_text("import sys\nfrom pathlib import Path\n"
                     "sys.path.insert(0, str(Path(__file__).parent))\n"                      # line 3
                     "code = 'import sys; sys.path.append(\"/elsewhere\")'\n"                # line 4
                     "from conftest import made\nimport test_bad_input\n"                    # tests, as top-level names
                     "from studies.donkeycar_tubs import blocks\nfrom donkeycar_tubs import TUBS\n"  # other studies
                     "from studies import track_recipes\nfrom . import same_batches\n"
                     "from studies.common import ROOT\nfrom studies._first_batches import main\nfrom . import common\n")
    assert _edits_sys_path(study) == [3, 4]
    assert _wrong_imports(study) == ["conftest.made", "test_bad_input", "studies.donkeycar_tubs.blocks",
                                     "donkeycar_tubs.TUBS", "studies.track_recipes", "studies.same_batches"]


def test_the_expert_is_recorded_on_every_place_of_a_suite_once(tmp_path):
    """The road suite's roads (the track suite's tracks go the same way, through the registry of worlds)."""
    from steerlab.data.readers import open_recording
    from steerlab.sim.worlds import WORLDS

    recs = common.record_expert("road", tmp_path, 0.01)
    roads = WORLDS["road"].suite.options().drives()
    first = tmp_path / "expert" / "country-9101"
    assert list(recs) == roads and recs[roads[0]] == first
    assert len(open_recording(first)) == 12  # 0.01 min at 20 frames/s
    (tmp_path / "replay" / "country-9101").mkdir(parents=True)
    stamp = (first / "minutes.json").stat().st_mtime_ns
    common.record_expert("road", tmp_path, 0.01)  # reused, with its replays
    assert (first / "minutes.json").stat().st_mtime_ns == stamp and (tmp_path / "replay" / "country-9101").exists()
    common.record_expert("road", tmp_path, 0.02)  # other minutes: recorded anew, the old replays deleted
    assert len(open_recording(first)) == 24 and not (tmp_path / "replay" / "country-9101").exists()


def test_the_lane_head_study_bins_by_the_true_pose_and_scores_against_the_spread_there():
    """`studies.lane_head.by_bin` on hand-made values: a head that reads the offset exactly and the heading not at all
    (it answers 0) has offset MAE 0 and heading MAE the bin's mean |heading|, and a bin's spread is the standard
    deviation of its true values; the last bin holds its upper edge."""
    import math

    import numpy as np

    from studies.lane_head import by_bin

    true = np.array([[0.01, 0.1, 0.0], [0.03, -0.3, 0.0], [0.3, 0.2, 1.0], [0.45, -0.4, 1.0]])
    predicted = true * np.array([1.0, 0.0, 1.0])
    rows = by_bin(true, predicted, 0, (0.0, 0.5, 1.0), 0.45)  # |offset| over a half lane of 0.45 m
    assert [(r["bin"], r["n"]) for r in rows] == [("0-0.5", 2), ("0.5-1", 2)]
    near, far = rows
    assert near["offset_mae_cm"] == 0 and far["offset_mae_cm"] == 0
    assert near["heading_mae_deg"] == pytest.approx(math.degrees(0.2))  # (0.1 + 0.3) / 2
    assert far["heading_mae_deg"] == pytest.approx(math.degrees(0.3))
    assert near["offset_sd_cm"] == pytest.approx(1.0)  # std of 0.01 and 0.03 m
    assert far["heading_sd_deg"] == pytest.approx(math.degrees(0.3))  # std of 0.2 and -0.4


def _keep_many(file, start: int) -> None:
    from studies.common import keep_result

    for i in range(start, start + 40, 2):
        keep_result(file, f"run {i}", {"i": i})


def test_studies_run_at_once_into_one_results_file_lose_none_of_each_others_runs(tmp_path):
    import json
    import multiprocessing

    from studies.common import keep_result

    file = tmp_path / "results.json"
    keep_result(file, "run a", {"mae": 0.1})
    assert keep_result(file, "run b", {"mae": 0.2}) == {"run a": {"mae": 0.1}, "run b": {"mae": 0.2}}  # a's kept
    assert keep_result(file, "run a", {"mae": 0.3})["run a"] == {"mae": 0.3}  # a run redone replaces its own
    ctx = multiprocessing.get_context("spawn")
    studies = [ctx.Process(target=_keep_many, args=(file, start)) for start in (0, 1)]  # even and odd runs at once
    for p in studies:
        p.start()
    for p in studies:
        p.join()
    held = json.loads(file.read_text())
    assert {f"run {i}" for i in range(40)} <= set(held) and held["run b"] == {"mae": 0.2}
    assert sorted(p.name for p in tmp_path.iterdir()) == ["results.json", "results.json.lock"]  # no half file left
