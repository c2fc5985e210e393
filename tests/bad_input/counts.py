"""The count of each rule's generated sweep (docs/results/bad-input.md, "Bad input"): `PYTHONPATH=src python -m
tests.bad_input.counts` prints the table of inputs generated, refused and said."""

from tests.bad_input.builders import _edges
from tests.bad_input.test_checkpoints import rule5_cases
from tests.bad_input.test_files import rule3_cases
from tests.bad_input.test_option_ranges import _cli_numeric_options, _numeric_options
from tests.bad_input.test_option_types import rule1_cases, rule1_named_set_cases, rule1_reader_cases, rule1_world_cases
from tests.bad_input.test_options_once import _single_value_flags
from tests.bad_input.test_outputs import rule2_cases
from tests.bad_input.test_plausible import rule4_cases


def rule_counts() -> list[tuple[str, int, int, int]]:
    """(rule, inputs generated, refused, said) of the rules' generated sweeps."""
    r1 = len(rule1_cases()) + len(rule1_world_cases()) + len(rule1_reader_cases()) + len(rule1_named_set_cases())
    edges = [_edges(check, kind) for _, kind, check, _ in _numeric_options()]
    cli = [_edges(check, kind) for _, _, kind, check in _cli_numeric_options()]
    taken = sum(t for e in edges for _, t in e)
    r1 += sum(map(len, edges)) + sum(1 for e in cli for v, t in e if not t and not isinstance(v, (bool, list)))
    r1 += 3 * len(_single_value_flags())  # each given twice: as it was, as --flag=value, abbreviated
    r3 = rule3_cases()
    r4 = rule4_cases()
    return [("1 every value checked where it enters", r1, r1 - taken, 0),
            ("2 no output over an input or into another's folder", len(rule2_cases()), len(rule2_cases()), 0),
            ("3 files as people save them", len(r3) + 1, sum(not t for _, _, t in r3), 0),
            ("4 implausible values said", len(r4), sum(o == "refused" for *_, o in r4),
             sum(o == "said" for *_, o in r4)),
            ("5 only earlier versions as earlier versions", len(rule5_cases()), sum(not t for _, t in rule5_cases()),
             0)]


if __name__ == "__main__":  # the table of docs/results/bad-input.md, "Bad input"
    print("| rule | inputs generated | refused | said |\n|---|---|---|---|")
    for rule, n, refused, said in rule_counts():
        print(f"| {rule} | {n} | {refused} | {said} |")
