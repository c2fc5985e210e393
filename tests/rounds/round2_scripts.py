"""Group E of the second round (round2.py): the scripts of studies/ and benchmarks/ with bad arguments, each run as
`python -m MODULE ARGV` from the repository of the build tried (`script`); a row is (script, argv, hint)."""

import os
import signal
import subprocess
import sys

from tests.rounds import places

F, W = "{fx}", "{work}"
CK, SIM, TUB = f"{F}/a.pt", f"{F}/sim", f"{F}/tub"
HERE = __name__

SCRIPTS = [
    ("studies/donkeycar_tubs.py", ["--seeds", "0"], ["--seeds"]),
    ("studies/donkeycar_tubs.py", ["--epochs", "-1"], ["--epochs"]),
    ("studies/donkeycar_tubs.py", ["--tubs", "nothere"], ["nothere"]),
    ("studies/donkeycar_tubs.py", ["--models", "pilot-net"], ["pilot-net"]),
    ("studies/pruning_replay.py", [f"{W}/nothere"], ["nothere"]),
    ("studies/pruning_replay.py", [SIM], ["study.journal", "sim"]),
    ("studies/pruning_replay.py", [CK], ["a.pt"]),
    ("studies/pruning_replay.py", [f"{F}/empty", "--factors", "0"], ["--factors", "empty"]),
    ("studies/replay_references.py", ["--data", f"{W}/nothere"], ["nothere"]),
    ("studies/replay_references.py", ["--data", CK], ["a.pt"]),
    ("studies/replay_references.py", ["--data", SIM, "--speed", "-3"], ["--speed"]),
    ("studies/replay_references.py", ["--data", SIM, "--checkpoint", f"{W}/gone.pt"], ["gone.pt"]),
    ("studies/replay_references.py", ["--data", SIM, "--lane-width", "0"], ["--lane-width"]),
    ("studies/replay_vs_road_suite.py", ["--minutes", "-1", "--out", f"{W}/rvr"], ["--minutes"]),
    ("studies/replay_vs_road_suite.py", ["--workers", "0", "--out", f"{W}/rvr"], ["--workers"]),
    ("studies/replay_vs_road_suite.py", ["--out", SIM], ["sim"]),
    ("studies/replay_vs_track_suite.py", ["--minutes", "0", "--out", f"{W}/rvt"], ["--minutes"]),
    ("studies/replay_vs_track_suite.py", ["--tubs", f"{W}/nothere", "--out", f"{W}/rvt"], ["nothere"]),
    ("studies/replay_vs_track_suite.py", ["--workers", "-1", "--out", f"{W}/rvt"], ["--workers"]),
    ("studies/replay_vs_track_suite.py", ["--out", TUB], ["tub"]),
    ("studies/same_batches.py", ["--before", f"{W}/nothere"], ["nothere"]),
    ("studies/same_batches.py", ["--before", "{repo}", "--batches", "0"], ["--batches"]),
    ("studies/same_batches.py", ["--before", "{repo}", "--config", f"{W}/nothere"], ["nothere"]),
    ("studies/track_recipes.py", ["--recipes", "foo", "--out", f"{W}/race"], ["foo"]),
    ("studies/track_recipes.py", ["--seeds", "x", "--out", f"{W}/race"], ["--seeds", "'x'"]),
    ("studies/track_recipes.py", ["--caps", "2", "--out", f"{W}/race"], ["--caps"]),
    ("studies/track_recipes.py", ["--workers", "0", "--out", f"{W}/race"], ["--workers"]),
    ("studies/track_recipes.py", ["--suite", "v1", "--out", f"{W}/race"], ["--suite", "v1"]),
    ("studies/track_recipes.py", ["--out", SIM], ["sim"]),
    ("studies/tub_pretraining.py", ["--seeds", "0"], ["--seeds"]),
    ("studies/tub_pretraining.py", ["--tubs", "nothere"], ["nothere"]),
    ("studies/tub_pretraining.py", ["--tubs", "wood-tape"], ["wood-tape"]),
    ("studies/tub_replay.py", ["--seeds", "0"], ["--seeds"]),
    ("studies/tub_replay.py", ["--tubs", "hall,hall"], ["hall"]),
    ("studies/speed_estimate.py", ["--minutes", "1"], ["--minutes", "unrecognized"]),
    ("benchmarks/bench_ddp.py", ["--epochs", "0"], ["--epochs"]),
    ("benchmarks/bench_ddp.py", ["--model", "pilot-net"], ["pilot-net"]),
    ("benchmarks/bench_serve.py", [f"{W}/gone.pt"], ["gone.pt"]),
    ("benchmarks/bench_serve.py", [SIM], ["sim"]),
    ("benchmarks/bench_throughput.py", ["--models", "foo"], ["foo"]),
    ("benchmarks/bench_track_drive.py", ["--minutes", "-1"], ["--minutes"]),
    ("benchmarks/bench_track_drive.py", ["--checkpoint", f"{W}/gone.pt"], ["gone.pt"]),
    ("benchmarks/bench_track_drive.py", ["--checkpoint", TUB], ["tub"]),
    ("benchmarks/bench_train_step.py", ["--before", "nothere"], ["nothere"]),
    ("benchmarks/bench_vs_donkeycar.py", ["--epochs", "0"], ["--epochs"]),
    ("benchmarks/bench_checkpoint.py", ["--json", SIM], ["sim", "--json"]),
    ("benchmarks/bench_checkpoint.py", ["--json", CK], ["a.pt", "--json"]),
    ("benchmarks/bench_pilot.py", ["--json", f"{F}/empty"], ["empty", "--json"]),
    ("benchmarks/bench_render.py", ["--json", f"{F}/c.yaml"], ["c.yaml", "--json"]),
    ("benchmarks/bench_compile.py", ["--frames", "10"], ["--frames"]),
    ("benchmarks/bench_stream.py", ["--threads", "2"], ["--threads"])
]
CASES = [{"name": f"{path} " + " ".join(argv), "build": f"{HERE}:script", "kwargs": {"path": path, "argv": argv},
          "hint": hint, "group": "E"} for path, argv, hint in SCRIPTS]


def script(path, argv, timeout=25):
    """`python -m MODULE ARGV` (PATH as a module) from the repository: its exit code and stderr, as the CLI's
    (argparse's usage line left out, `prog: error:` read as `error:`); still running after `timeout` s: taken
    (exit code 0)."""
    module = path.removesuffix(".py").replace("/", ".")
    p = subprocess.Popen([sys.executable, "-m", module, *map(str, argv)], cwd=places.REPO, stdout=subprocess.DEVNULL,
                         stderr=subprocess.PIPE, text=True, start_new_session=True)
    try:
        _, err = p.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        os.killpg(p.pid, signal.SIGKILL)
        p.communicate()
        print(f"still running after {timeout} s", file=sys.stderr)
        return 0
    if "Traceback" in err:
        print(err, file=sys.stderr)
        return 1
    lines = [line for line in err.splitlines() if line.strip()]
    said = [("error:" + line.split(": error:", 1)[1]) if ": error:" in line else line for line in lines
            if not line.startswith(("usage:", "   ")) and ("error:" in line or "warning:" in line)]
    print("\n".join(said or lines), file=sys.stderr)
    return 2 if p.returncode in (1, 2) and said else p.returncode
