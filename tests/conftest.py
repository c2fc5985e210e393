import multiprocessing as mp
import os
import subprocess
import sys
from pathlib import Path

import cv2
import numpy as np
import pytest

# the tiny inputs of tests/inputs.py that most tests use, passed on: they import them from here
from tests.inputs import flip_bytes, made, write_jpeg  # noqa: F401

# the helpers of tests that assert, their asserts explained on failure as a test's own are
pytest.register_assert_rewrite("tests.bad_input.builders")

if os.environ.get("PYTEST_XDIST_WORKER"):  # two test processes on two cores: one torch thread each
    import torch

    torch.set_num_threads(1)

SHARED = Path(__file__).resolve().parents[1].parent / "shared" / "data"
CH2 = SHARED / "udacity-ch2"
SIM = SHARED / "udacity-sim-track1"

needs_ch2 = pytest.mark.skipif(not (CH2 / "CH2_final_evaluation.csv").exists(), reason="../shared/data absent")
needs_sim = pytest.mark.skipif(not (SIM / "driving_log.csv").exists(), reason="../shared/data absent")


@pytest.fixture(autouse=True)
def _nothing_said_yet():
    """Every test starts as a fresh process does: what `errors.warn_once` said in an earlier test is said again."""
    from steerlab import errors

    errors._SAID.clear()


@pytest.fixture
def ch2_folder(tmp_path):
    """A tiny CH2-layout folder (tmp_path/ch2, beside the outputs of a test): 6 frames of 640x480, answer-file
    labels."""
    folder = tmp_path / "ch2"
    (folder / "center").mkdir(parents=True)
    ids = [1_000_000_000 + i * 50_000_000 for i in range(6)]
    for i, fid in enumerate(ids):
        write_jpeg(folder / "center" / f"{fid}.jpg", 40 * i, (480, 640))
    lines = ["frame_id,steering_angle,public"] + [f"{fid},{0.01 * i},{i % 2}" for i, fid in enumerate(ids)]
    (folder / "labels.csv").write_text("\n".join(lines) + "\n")
    return folder


# Command-line worker processes of the tests (tuning workers, as on several machines) are forked from a server process
# that imported torch, its compiler module (which torch.optim imports), steerlab and the database layer of Optuna's
# storages (SQLAlchemy and alembic) once, as the closed-loop workers
# are (steerlab/sim/parallel.py): each is a process of its own that runs `steerlab.cli.main(argv)`, without paying
# about 4 s of imports. The server starts with the session, in every process that runs tests, so that it is the one
# the closed-loop workers fork from too.
PRELOAD = ["torch", "torch._dynamo", "optuna", "steerlab.cli", "steerlab.train.loop", "steerlab.tune.run",
           "steerlab.sim.road.suite", "sqlalchemy.orm", "alembic.context"]


def pytest_configure(config):
    config.addinivalue_line("markers", "figures: the test looks at the PNGs steerlab draws (see _figures_unrendered)")
    if hasattr(config, "workerinput") or not getattr(config.option, "numprocesses", None):  # not xdist's controller
        from multiprocessing import forkserver

        mp.get_context("forkserver").set_forkserver_preload(PRELOAD)
        try:
            forkserver.ensure_running()
        except ChildProcessError:  # a run in a process forked from one that started the server (mutmut's workers):
            server = forkserver._forkserver  # that server is not its child; it starts its own if a test needs one
            server._forkserver_pid = server._forkserver_address = server._forkserver_alive_fd = None


def pytest_report_header(config):
    """The CPU the suite runs on (tolerances must hold on every CPU: a failure says which one it was seen on)."""
    from steerlab.cpu import instruction_sets, model_name

    limits = ", ".join(f"{k}={os.environ[k]}" for k in ("ATEN_CPU_CAPABILITY", "ONEDNN_MAX_CPU_ISA") if k in os.environ)
    return f"cpu: {model_name()} ({instruction_sets()}){'; ' + limits if limits else ''}"


def pytest_terminal_summary(terminalreporter):
    terminalreporter.write_line(pytest_report_header(terminalreporter.config))


def _run_cli(argv: list[str], env: dict, cwd: str, stderr: str, prelude: str) -> None:
    """In a forked worker: the caller's environment and folder, stderr into a file, `prelude` run first."""
    import torch

    os.environ.clear()
    os.environ.update(env)
    os.chdir(cwd)
    torch.set_num_threads(int(env.get("OMP_NUM_THREADS", "1")))
    with open(os.devnull, "w") as null, open(stderr, "w") as err:
        os.dup2(null.fileno(), 1)
        os.dup2(err.fileno(), 2)
    exec(prelude, {})
    from multiprocessing import resource_tracker
    from steerlab.cli import main

    # a resource tracker of its own, as a process started afresh has: the semaphores a killed worker leaves behind
    # are reported in its stderr file, not by the tracker of the tests
    tracker = resource_tracker.ResourceTracker()
    for name in ("ensure_running", "register", "unregister", "getfd"):
        setattr(resource_tracker, name, getattr(tracker, name))

    sys.exit(main(argv))


class CliProcess:
    """`steerlab ARGV` in a process of its own (see PRELOAD), with what the tests use of a `subprocess.Popen`:
    poll, wait, send_signal, returncode, and `errors()`, what it wrote to stderr."""

    def __init__(self, argv: list[str], stderr: Path, env: dict | None = None, prelude: str = ""):
        self.stderr_path = stderr
        self.process = mp.get_context("forkserver").Process(
            target=_run_cli, args=(list(argv), dict(os.environ if env is None else env), os.getcwd(), str(stderr),
                                   prelude))
        self.process.start()

    @property
    def returncode(self) -> int | None:
        return self.process.exitcode

    def poll(self) -> int | None:
        return self.process.exitcode

    def wait(self, timeout: float | None = None) -> int:
        self.process.join(timeout)
        if self.process.exitcode is None:
            raise subprocess.TimeoutExpired(["steerlab"], timeout)
        return self.process.exitcode

    def send_signal(self, sig: int) -> None:
        if self.process.exitcode is None:
            os.kill(self.process.pid, sig)

    def errors(self) -> str:
        return self.stderr_path.read_text() if self.stderr_path.exists() else ""


def once_per_session(tmp_path_factory, name: str, make) -> Path:
    """The folder `name`, filled by `make(folder)` once per test session however many worker processes run it: the
    first worker to ask makes it in the folder of the whole session, the others wait for it and read it."""
    import fcntl
    import shutil

    root = tmp_path_factory.getbasetemp()
    if os.environ.get("PYTEST_XDIST_WORKER"):
        root = root.parent  # above every worker's own folder
    folder = root / name
    with open(root / f"{name}.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        if not (folder / ".made").exists():
            shutil.rmtree(folder, ignore_errors=True)
            folder.mkdir()
            make(folder)
            (folder / ".made").touch()
    return folder


@pytest.fixture(scope="session")
def tiny_recording(tmp_path_factory):
    """A short synthetic recording with all three cameras (shared by several tests)."""
    from steerlab.sim.road.run import record
    from steerlab.sim.road.world import RecordOptions

    return once_per_session(tmp_path_factory, "rec",
                            lambda f: record(f / "rec", RecordOptions(seed=3, minutes=0.25), progress=False)) / "rec"


@pytest.fixture(scope="session")
def track_tub(tmp_path_factory):
    """3.6 s of the racing expert (no drift episodes) on track 5 of the track world, as a tub (read, never written,
    by the tests that share it)."""
    from steerlab.cli import main

    def make(folder):
        assert main(["sim", "record", "--world", "track", "--seed", "5", "--minutes", "0.06", "--no-drift",
                     "--out", str(folder / "tub")]) == 0

    return once_per_session(tmp_path_factory, "track-tub", make) / "tub"


@pytest.fixture(scope="session")
def tiny_checkpoint(tiny_recording, tmp_path_factory):
    """PilotNet trained for one epoch on the tiny recording: a real checkpoint for the closed-loop tests."""
    from steerlab.train.config import load_config
    from steerlab.train.loop import train

    def make(folder):
        train(load_config(None, base={"data": str(tiny_recording), "cache": str(folder / "cache"),
                                      "out": str(folder / "run"), "split": {"train": "0:240", "val": "240:300"},
                                      "train": {"epochs": 1, "batch_size": 32}}), progress=False)

    return once_per_session(tmp_path_factory, "ckpt", make) / "run" / "best.pt"


@pytest.fixture
def donkeycar_tub():
    """donkeycar's tub module (its import prints a banner and sets the root logger to INFO: undone)."""
    import logging

    root = logging.getLogger()
    handlers, level = root.handlers[:], root.level
    tub_v2 = pytest.importorskip("donkeycar.parts.tub_v2", reason="donkeycar is not installed")
    root.handlers[:] = handlers
    root.setLevel(level)
    return tub_v2


def resaved(path, ckpt) -> None:
    """A checkpoint edited on purpose (its statistics or convention changed by a test), saved as steerlab saves it."""
    from steerlab.checkpoint import save_payload

    save_payload(path, ckpt)


# Plots and videos: what a test reads of them beside the file. A figure is checked where it is drawn (its lines and
# their points, its legend) and in the PNG written from it (its size, the pixels of its lines); a video by its frames.

@pytest.fixture(autouse=True)
def _figures_unrendered(request, monkeypatch):
    """A figure is built as steerlab builds it, but drawn into its PNG only in a test that looks at figures (one that
    asks for `saved_figures` or is marked `figures`); elsewhere an empty file stands in for the PNG, and laying the
    figure out (which draws its text) is left out too: a suite's plots cost their plotting calls, not their
    rendering. Figures saved in other processes (the workers of a suite, a command run as a process) are drawn."""
    if "saved_figures" in request.fixturenames or request.node.get_closest_marker("figures"):
        return
    from matplotlib.figure import Figure

    def placeholder(fig, path, *args, **kwargs):
        if hasattr(path, "write"):
            path.write(b"")
        else:
            Path(path).write_bytes(b"")

    monkeypatch.setattr(Figure, "savefig", placeholder)
    monkeypatch.setattr(Figure, "tight_layout", lambda fig, *args, **kwargs: None)


@pytest.fixture
def saved_figures(monkeypatch):
    """Every matplotlib figure saved in this process while the test runs, by the path it was saved to (as text),
    kept after steerlab closes it."""
    from matplotlib.figure import Figure

    saved, save = {}, Figure.savefig

    def keep(fig, path, *args, **kwargs):
        saved[str(path)] = fig
        return save(fig, path, *args, **kwargs)

    monkeypatch.setattr(Figure, "savefig", keep)
    return saved


def image_of(path) -> np.ndarray:
    """A PNG (or any image file) as OpenCV reads it: (height, width, 3) BGR."""
    img = cv2.imread(str(path))
    assert img is not None, f"{path} is not an image"
    return img


def legend_of(ax) -> list[str]:
    legend = ax.get_legend()
    assert legend is not None, "the axes have no legend"
    return [text.get_text() for text in legend.get_texts()]


def _inked(img: np.ndarray, color) -> np.ndarray:
    """Which pixels of a saved figure show the matplotlib colour `color`, alone or blended with the white background
    as the edges of an antialiased line are (at least a third of the colour)."""
    from matplotlib.colors import to_rgb

    white, ink = np.full(3, 255.0), np.array(to_rgb(color))[::-1] * 255  # BGR, as OpenCV reads
    pixels = img.astype(float)
    share = ((white - pixels) @ (white - ink)) / max(float((white - ink) @ (white - ink)), 1.0)
    residual = np.linalg.norm(pixels - (white + share[..., None] * (ink - white)), axis=2)
    return (share >= 1 / 3) & (residual < 30)


def drawn_pixels(img: np.ndarray, ax, color) -> int:
    """How many pixels of the saved figure `img` inside the axes `ax` (their frame and legend left out) show the
    matplotlib colour `color` (`_inked`): what the artists of that colour drew."""
    height = img.shape[0]

    def box(artist, inset=0):  # the artist's extent in the image's pixel rows and columns
        b = artist.get_window_extent()
        return (max(int(height - b.y1) + inset, 0), int(height - b.y0) - inset,
                max(int(b.x0) + inset, 0), int(b.x1) - inset)

    near = _inked(img, color)
    inside = np.zeros_like(near)
    r0, r1, c0, c1 = box(ax, inset=3)
    inside[r0:r1, c0:c1] = True
    if ax.get_legend() is not None:
        r0, r1, c0, c1 = box(ax.get_legend())
        inside[r0:r1, c0:c1] = False
    return int((near & inside).sum())


def drawn_along(img: np.ndarray, ax, line) -> float:
    """The share of a line's points (its finite data points) at which the saved figure `img` shows the line's colour
    within a pixel: a line drawn invisibly (no width, transparent, hidden) is near 0 however many markers of its
    colour the axes hold elsewhere."""
    xy = line.get_xydata()
    xy = xy[np.isfinite(xy).all(axis=1)]
    cols, rows = ax.transData.transform(xy).T
    rows = img.shape[0] - rows
    near = _inked(img, line.get_color())
    seen = [near[max(int(r) - 1, 0): int(r) + 2, max(int(c) - 1, 0): int(c) + 2].any() for r, c in zip(rows, cols)]
    return float(np.mean(seen)) if seen else 0.0


def video_frames(path) -> list[np.ndarray]:
    """Every frame of a video file, decoded."""
    video, frames = cv2.VideoCapture(str(path)), []
    while True:
        ok, frame = video.read()
        if not ok:
            return frames
        frames.append(frame)


def assert_video(path, count: int, size: tuple[int, int]) -> list[np.ndarray]:
    """The video has `count` frames of `size` (width, height), and they move: at least half of the consecutive
    pairs differ (a video of one repeated frame, or of blank frames, fails)."""
    frames = video_frames(path)
    assert len(frames) == count
    assert {f.shape for f in frames} == {(size[1], size[0], 3)}
    moved = sum(np.abs(a.astype(int) - b).mean() > 0.5 for a, b in zip(frames, frames[1:]))
    assert moved >= (count - 1) / 2, f"{moved} of {count - 1} consecutive frames differ"
    assert min(float(f.std()) for f in frames) > 5  # none blank
    return frames
