"""How steerlab starts worker processes (the closed loop's drives, replays and rollouts; training's data-loading
workers): forked from a server process (multiprocessing's "forkserver") that imported torch and the workers' module
once, when this process first needed workers, so that a worker starts in milliseconds instead of seconds of
imports, and no process that already runs torch threads is ever forked. Where there is no forkserver, workers are
spawned afresh."""

from __future__ import annotations

import multiprocessing as mp


def worker_context(module: str):
    """The multiprocessing context whose workers run code of `module` (a dotted name)."""
    if "forkserver" not in mp.get_all_start_methods():
        return mp.get_context("spawn")
    ctx = mp.get_context("forkserver")
    ctx.set_forkserver_preload(["torch", module])  # used when this process's server starts
    return ctx
