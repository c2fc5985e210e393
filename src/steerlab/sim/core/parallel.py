"""The one parallel runner of closed-loop work: drives of the suite, replays of checkpoints, rollouts. Jobs run in
worker processes with one torch thread each (started as `processes.worker_context` says), with one progress bar
over the ticks of all of them. Each worker takes the caller's current environment."""

from __future__ import annotations

import os
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait

from tqdm import tqdm

from steerlab.processes import worker_context

_ticks = None  # in a worker: the queue through which it reports progress


def _init_worker(queue, environ: dict) -> None:
    global _ticks
    import torch

    os.environ.clear()  # the caller's, not the one the server started with
    os.environ.update(environ)
    torch.set_num_threads(1)
    _ticks = queue


def tick_reporter():
    """In a worker process: the callback through which a drive reports its ticks (None elsewhere)."""
    return _ticks.put if _ticks is not None else None


def run_parallel(fn, jobs: list[tuple], workers: int, ticks_per_job: int, progress: bool, desc: str) -> list:
    """`fn(*job)` for every job, in `workers` worker processes with one torch thread each (in this process when
    workers <= 1 or there is one job). `ticks_per_job`: the frames a job drives (its minutes times the frame rate
    of its world or recording), for the progress bar. Results in job order."""
    results = [None] * len(jobs)
    with tqdm(total=ticks_per_job * len(jobs), desc=desc, unit="tick", disable=None if progress else True) as bar:
        if workers <= 1 or len(jobs) <= 1:
            for i, job in enumerate(jobs):
                results[i] = fn(*job)
                bar.update(ticks_per_job)
            return results
        ctx = worker_context(fn.__module__)
        queue = ctx.Queue()
        with ProcessPoolExecutor(min(workers, len(jobs)), ctx, _init_worker, (queue, dict(os.environ))) as pool:
            futures = {pool.submit(fn, *job): i for i, job in enumerate(jobs)}
            pending = set(futures)
            try:
                while pending:
                    finished, pending = wait(pending, timeout=0.5, return_when=FIRST_COMPLETED)
                    while not queue.empty():
                        bar.update(queue.get())
                    for f in finished:
                        results[futures[f]] = f.result()
            except BaseException:  # Ctrl-C or a job's error: the jobs not started are dropped, not run to the end
                pool.shutdown(cancel_futures=True)
                raise
        bar.update(bar.total - bar.n)
    return results
