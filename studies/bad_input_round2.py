"""A second new user's round: inputs that neither the bad-input tests nor the first round
(studies/bad_input_round.py) list: every command given the wrong kind of file, runs interrupted and rerun, mixed
recordings, the Python API with wrong types and units, and the scripts of studies/ and benchmarks/ with bad
arguments. Each case is run and classified by the first round's own code (its fixtures, `run_case` and `classify`);
the cases are studies/_round2_cases.py. The counts are printed, and every input not handled is written to
OUT_DIR/failures.txt.

usage: python -m studies.bad_input_round2 OUT_DIR    (from the repository root)"""

import shutil
import sys
import time
from collections import Counter

from steerlab.cli import run_script
from studies import _round_cases as inputs
from studies import bad_input_round as first
from studies._round2_cases import main_cases, setup


def snapshot():
    """The first round's snapshot of the fixtures but a stale lock a command takes over (a killed run's `.lock`,
    emptied when it is released): a lock is no result nor input."""
    return {p: t for p, t in first.snapshot().items() if p.name != ".lock"}


def main(a):
    first.begin(a.out_dir)
    root = inputs.ROOT
    setup()
    cases = main_cases()
    counts, bad, start = Counter(), [], time.monotonic()
    for n, case in enumerate(cases):
        if n % 50 == 0:
            print(f"{n}/{len(cases)} ({time.monotonic() - start:.0f} s)", file=sys.stderr, flush=True)
        before = snapshot()
        first.TIMEOUT = case.get("timeout", 45)  # an interrupted run and its rerun: two commands' start-up
        result = first.run_case(case["fn"])
        after = snapshot()
        cls = first.classify(case, result, before, after)
        cls = "handled" if cls == "silent-refusal" else cls  # refused though acceptable: counted as handled
        if cls == "handled" and case.get("after"):
            cls = case["after"]() or cls  # what the case checks on disk afterwards (an output it must keep)
        counts[cls] += 1
        if cls != "handled":
            code, err, exc, *_ = result
            said = (exc.strip().splitlines() or [""])[-1][:300] if exc else err.strip()[-300:]
            bad.append(f"{cls:<10} [{case['group']}] {case['name'][:200]}\n           {said}")
        if cls == "lost":  # the fixtures back for the next case
            shutil.rmtree(inputs.FIX)
            first.setup()
            setup()
    groups = Counter(case["group"] for case in cases)
    print(f"{len(cases)} inputs ({', '.join(f'{g} {k}' for g, k in groups.items())}) in "
          f"{time.monotonic() - start:.0f} s: " + ", ".join(f"{k} {v}" for k, v in counts.most_common()))
    (root / "failures.txt").write_text("\n".join(bad) + "\n")
    print("\n".join(bad))


if __name__ == "__main__":
    run_script(first.parser(__spec__.name, __doc__), main)
