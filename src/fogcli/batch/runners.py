"""`fogcli batch`: find the frames of a folder, run them here, in spawned worker processes
or on a Dask cluster, and report. One bad file never stops the batch; outputs are atomic,
so a killed run leaves only whole outputs (and stale temporary files, removed by the next
run), and --skip-existing resumes it."""
from __future__ import annotations

import contextlib
import itertools
import os
import queue
import signal
import sys
import threading
import time
from collections import deque
from pathlib import Path

from fogcli.errors import UserError
from fogcli.io import openimageio
from fogcli.frame.job import Job
from fogcli.batch.discover import STALE, check_report, check_side_outputs, discover, remove_stale_temporaries
from fogcli.batch.progress import Progress, Summary, write_report
from fogcli.batch.worker_count import auto_jobs, frame_pixels, usable_cores


END = object()


class Source:
    """Jobs one at a time for the batch's runners: from a list, or from a stream whose lines
    are read on a thread of their own (so that a frame runs while the next line is awaited).
    get(block=False) says None when no job is ready yet; END at the end. Items that are not
    jobs (a bad line, a skipped output) go to `report`, on the caller's thread."""

    def __init__(self, items, report=None, stream: bool = False):
        """report: called with every item that is not a Job (None: there are none)."""
        self._front: deque = deque()
        self._report = report
        self._it = iter(items)
        self._q: queue.Queue | None = None
        if stream:
            self._q = queue.Queue()
            threading.Thread(target=self._pump, name="fogcli-jobs", daemon=True).start()

    def _pump(self):
        try:
            for item in self._it:
                self._q.put(item)
        except BaseException as exc:      # handed to the reader, raised there
            self._q.put(_Raised(exc))
        self._q.put(END)

    def _next(self, block: bool):
        if self._q is None:
            return next(self._it, END)
        try:
            item = self._q.get(block)
        except queue.Empty:
            return None
        if isinstance(item, _Raised):
            raise item.exc
        if item is END:
            self._q.put(END)      # stays at the end
        return item

    def get(self, block: bool = True):
        while True:
            if self._front:
                return self._front.popleft()
            item = self._next(block)
            if item is None or item is END or isinstance(item, Job):
                return item
            self._report(item)

    def pushback(self, jobs) -> None:
        self._front.extendleft(reversed(list(jobs)))


class _Raised:
    def __init__(self, exc):
        self.exc = exc


# -- workers ---------------------------------------------------------------------------
_WORKER: dict = {}


def _die_with_parent() -> None:
    """A worker must not outlive a killed batch (it would keep writing into OUTPUT_DIR)."""
    if sys.platform.startswith("linux"):
        import ctypes

        try:
            ctypes.CDLL("libc.so.6", use_errno=True).prctl(1, signal.SIGKILL)   # PR_SET_PDEATHSIG
        except OSError:
            pass


def init_worker(cfg, aovs, device, threads: int | None, started=None) -> None:
    """Runs first in each spawned worker, before OpenCL is touched: PoCL's thread count
    is fixed when the device is created. `started` (a SimpleQueue) hears the input of
    every frame a worker begins, so that a worker that dies (a decoder crash) can be traced
    to its frame."""
    _die_with_parent()
    if threads:
        # PoCL 3.0's pthread device reads POCL_MAX_PTHREAD_COUNT, later ones POCL_CPU_MAX_CU_NUM
        os.environ.setdefault("POCL_CPU_MAX_CU_NUM", str(threads))
        os.environ.setdefault("POCL_MAX_PTHREAD_COUNT", str(threads))
        oiio = openimageio.load()

        # OpenEXR's own pool (zip compression) keeps a thread per core unless told: with
        # workers on every core, those threads only fought over them (tools/throughput.py)
        oiio.attribute("threads", threads)
        oiio.attribute("exr_threads", threads)
    _WORKER.update(cfg=cfg, aovs=aovs, device=device, started=started)


def process(job: Job, cfg=None, aovs=None, device=None) -> dict:
    """One job; never raises for a bad input: returns {'ok', 'input', 'output', 'reason'}."""
    from fogcli.frame.job import run_job

    cfg = job.cfg if job.cfg is not None else cfg if cfg is not None else _WORKER["cfg"]
    aovs = aovs if aovs is not None else _WORKER.get("aovs", ())
    device = device if device is not None else _WORKER.get("device")
    if _WORKER.get("started") is not None:
        _WORKER["started"].put(job.input)
        # test hook: this frame kills its worker, as a segfault in a decoder would
        if os.environ.get("FOGCLI_TEST_KILL_WORKER") == Path(job.input).name:
            os.kill(os.getpid(), 9)
    t0 = time.perf_counter()
    res, failed = _attempt(job, lambda: run_job(_make_folders(job), cfg, aovs=aovs, device=device))
    return failed or _done(job, res, t0)


def _make_folders(job: Job) -> Job:
    for p in (job.output, job.save_depth):
        if p:
            parent = Path(p).parent
            try:
                parent.mkdir(parents=True, exist_ok=True)
            except OSError as exc:
                raise UserError(f"{p}: cannot create folder {parent} ({exc.strerror})") from None
    if job.label:           # a jobs file's output: what a killed run left of it goes first
        STALE.remove_for(Path(job.output))
    return job


def _done(job: Job, res, t0: float) -> dict:
    return {"ok": True, "input": job.input, "output": job.output, "warnings": res.warnings,
            "seconds": round(time.perf_counter() - t0, 3), "line": job.label}


def _attempt(job: Job, fn):
    """(fn(), None), or (None, the failure's report): a bad input never stops a batch."""
    from fogcli.errors import ProcessingError

    try:
        return fn(), None
    except (UserError, ProcessingError) as exc:
        reason = str(exc)
    except Exception as exc:  # a worker reports, it does not die
        reason = f"processing failed: {exc.__class__.__name__}: {exc}"
    return None, {"ok": False, "input": job.input, "output": job.output, "reason": reason, "line": job.label}


# --jobs 1: frames being written at once. The EXR write is most of a frame's core time (zip
# of float noise) and runs serially within one file, so one write at a time left a core idle
# while the device waited for it (tools/throughput.py); the pixel budget keeps large
# frames to one (~40 bytes a pixel held per frame being written).
WRITES_IN_FLIGHT, WRITE_BUDGET_PIXELS = 2, 8_000_000


def _overlapped(source, cfg, aovs, device, progress, collect) -> None:
    """--jobs 1: while frame n runs on the device (this thread), frame n + 1 is read and its
    depth cleaned and frames n - 1 and n - 2 written (WRITES_IN_FLIGHT), on threads
    (OpenImageIO and numpy release the GIL; OpenCL stays on this thread). Results are
    reported in input order. From a stream, the next frame is read ahead only once its line
    has come; while none has, the writes in flight are finished and reported."""
    from concurrent.futures import ThreadPoolExecutor

    from fogcli.frame.job import compute, load, store

    def read(job):
        t0 = time.perf_counter()
        st, failed = _attempt(job, lambda: load(_make_folders(job), job.cfg or cfg, aovs))
        return job, t0, st, failed

    def write(job, t0, st):
        res, failed = _attempt(job, lambda: store(st, job.cfg or cfg))
        return failed or _done(job, res, t0)

    with ThreadPoolExecutor(max_workers=1 + WRITES_IN_FLIGHT, thread_name_prefix="fogcli-io") as io:
        writing: list = []         # (future, pixels), oldest first

        def next_read(block: bool):
            job = source.get(block=False)
            if job is None and block:
                while writing:              # nothing to do but wait for the next line
                    collect(writing.pop(0)[0].result(), progress)
                job = source.get(block=True)
            return None if job is None or job is END else io.submit(read, job)

        ahead = next_read(True)
        while ahead is not None:
            job, t0, st, failed = ahead.result()
            ahead = next_read(False)
            if failed is None:
                st, failed = _attempt(job, lambda: compute(st, job.cfg or cfg, aovs, device))
            px = st.rgb.shape[0] * st.rgb.shape[1] if failed is None else 0
            while writing and (len(writing) >= WRITES_IN_FLIGHT or failed is not None
                               or px + sum(n for _, n in writing) > WRITE_BUDGET_PIXELS):
                collect(writing.pop(0)[0].result(), progress)
            if failed is not None:
                collect(failed, progress)
            else:
                writing.append((io.submit(write, job, t0, st), px))
            if ahead is None:
                ahead = next_read(True)
        for w, _ in writing:
            collect(w.result(), progress)


def _fill(source, futs: dict, limit: int, submit) -> bool:
    """The source's jobs submitted (submit(job) -> its future, into futs) until `limit` are
    in flight or none is ready yet, waiting for one only while none is in flight. True: the
    source has ended."""
    while len(futs) < limit:
        job = source.get(block=not futs)
        if job is None:
            return False
        if job is END:
            return True
        futs[submit(job)] = job
    return False


@contextlib.contextmanager
def _children_ignore_ctrl_c():
    """Worker processes started in here ignore SIGINT (a disposition that a spawned Python
    keeps): Ctrl-C at a terminal reaches the whole process group, and is this process's to
    take: it stops the workers and the command. Workers taking it too printed tracebacks
    from wherever they were (an import, Dask's event loop). A Ctrl-C in here is lost (the
    start of a process: milliseconds; of a Dask LocalCluster: a second or two)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    old = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, old)


def _pool(source, workers, cfg, aovs, device, threads, progress, collect):
    """Run the source's jobs on `workers` spawned processes, at most two a worker in
    flight (a stream's lines are taken as they come). Returns (crashed, the jobs that had
    started but not finished) and puts the ones never started back into the source."""
    import multiprocessing as mp
    from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
    from concurrent.futures.process import BrokenProcessPool

    ctx = mp.get_context("spawn")
    # If this process is killed (-9), multiprocessing's resource tracker unlinks the pool's
    # semaphores, and says so with a "leaked semaphore" warning. The cleanup is the
    # tracker's job, the warning is noise to a user: the tracker inherits -W options from
    # sys.warnoptions when it starts (with the first semaphore, just below).
    quiet = "ignore::UserWarning:multiprocessing.resource_tracker"
    if quiet not in sys.warnoptions:
        sys.warnoptions.append(quiet)
    started = ctx.SimpleQueue()
    with ProcessPoolExecutor(max_workers=workers, mp_context=ctx, initializer=init_worker,
                             initargs=(cfg, aovs, device, threads, started)) as ex:
        futs: dict = {}
        crashed, ended = False, False
        def submit(job):
            with _children_ignore_ctrl_c():            # a submit may spawn a worker
                try:
                    return ex.submit(process, job)
                except BrokenProcessPool:
                    source.pushback([job])             # never started: the next pool runs it
                    raise

        while not crashed and (futs or not ended):
            try:
                ended = ended or _fill(source, futs, 2 * workers, submit)
            except BrokenProcessPool:    # a worker died after the last wait, before this submit
                crashed = True
                break
            if not futs:
                continue
            try:
                finished, _ = wait(futs, timeout=None if ended else 0.2, return_when=FIRST_COMPLETED)
            except KeyboardInterrupt:     # the frames in flight are dropped (outputs are atomic)
                for child in mp.active_children():
                    child.terminate()
                raise
            for f in finished:
                job = futs.pop(f)
                try:
                    r = f.result()
                except BrokenProcessPool:
                    crashed = True
                    futs[f] = job
                    continue
                collect(r, progress)
    if not crashed:
        return False, []
    for f in [f for f in futs if f.done() and f.exception() is None]:
        collect(f.result(), progress)              # finished before the pool broke
        del futs[f]
    began = set()
    while not started.empty():
        began.add(started.get())
    rest = list(futs.values())
    source.pushback([j for j in rest if j.input not in began])
    return True, [j for j in rest if j.input in began]


def _local(source, cfg, aovs, device, n_jobs, progress, collect):
    """In this process (--jobs 1), or on spawned workers. A worker that dies takes its
    frame with it, and the pool breaks: the frames it had not started are rerun on a new
    pool; the ones in flight are rerun one at a time, so the frame that kills a worker
    again is known, and reported as failed."""
    if n_jobs <= 1:
        _overlapped(source, cfg, aovs, device, progress, collect)
        return
    threads = max(1, usable_cores() // n_jobs)
    while True:
        crashed, suspects = _pool(source, n_jobs, cfg, aovs, device, threads, progress, collect)
        if not crashed:
            return
        for job in suspects:
            again, _ = _pool(Source([job]), 1, cfg, aovs, device, usable_cores(), progress, collect)
            if again:
                collect({"ok": False, "input": job.input, "output": job.output, "line": job.label,
                         "reason": "the worker process died on this frame (killed or crashed)"}, progress)


def _dask(source, cfg, aovs, device, scheduler, progress, collect):
    try:
        from dask.distributed import Client, LocalCluster, wait
    except ImportError:
        raise UserError("--scheduler needs Dask: pip install 'dask[distributed]'") from None
    import logging

    # A Ctrl-C that lands inside distributed's sync() (a wait below) makes its cancel
    # callback raise NameError on the event loop thread, which tornado logs with a
    # traceback (distributed 2026.8; seen once in a full test run): the interrupt is
    # this command's to report, in one line
    logging.getLogger("tornado.application").setLevel(logging.CRITICAL)
    cluster = None
    if scheduler.startswith("local"):
        n = scheduler.partition(":")[2] or str(usable_cores())
        if not n.isdigit() or int(n) < 1:
            raise UserError(f"--scheduler {scheduler}: expected local:N with N >= 1 workers")
        import dask

        # workers are spawned (never forked, PoCL hangs in a forked child) and share the
        # cores: each gets cores / N PoCL and OpenImageIO threads, like --jobs N
        threads = str(max(1, usable_cores() // int(n)))
        dask.config.set({"distributed.worker.multiprocessing-method": "spawn"})
        with _children_ignore_ctrl_c():
            cluster = LocalCluster(n_workers=int(n), threads_per_worker=1, processes=True,
                                   # CRITICAL: a worker whose scheduler went first at Ctrl-C logs its
                                   # lost heartbeat with a traceback (seen under load); a frame's
                                   # failure still reaches the report through its future
                                   dashboard_address=None, silence_logs=logging.CRITICAL,
                                   env={"POCL_MAX_PTHREAD_COUNT": threads, "POCL_CPU_MAX_CU_NUM": threads,
                                        "OPENIMAGEIO_THREADS": threads})
        client = Client(cluster)
    else:
        try:
            client = Client(scheduler, timeout="20s")
        except (OSError, TimeoutError) as exc:
            raise UserError(f"--scheduler {scheduler}: cannot connect ({exc})") from None
    try:
        # process() with the config as arguments: a Dask worker has no init_worker; its
        # kernels are built once per worker process by the runtime cache. Lines of a stream
        # are submitted as they come, a bounded number in flight.
        limit = max(64, 4 * len(client.scheduler_info().get("workers", {})))
        futs: dict = {}
        ended, count = False, itertools.count()

        def submit(job):
            return client.submit(process, job, cfg, aovs, device, pure=False, key=f"fogcli-{next(count)}-{job.input}")

        while futs or not ended:
            ended = ended or _fill(source, futs, limit, submit)
            if not futs:
                continue
            try:
                done, _ = wait(list(futs), timeout=None if ended else 0.2, return_when="FIRST_COMPLETED")
            except TimeoutError:        # none finished yet: look for more lines
                continue
            for f in done:
                job = futs.pop(f)
                try:
                    r = f.result()
                except Exception as exc:   # a worker lost mid-task
                    r = {"ok": False, "input": job.input, "output": job.output, "line": job.label,
                         "reason": f"worker failed: {exc}"}
                collect(r, progress)
    finally:
        client.close()
        if cluster is not None:
            cluster.close()


def _run(items, stream: bool, total, cfg, aovs, device, jobs, scheduler, quiet, summary: "Summary",
         size: int | None = None) -> None:
    """Every job of `items` (Jobs, and results of lines that are not: jobs_file.Parser)
    through the chosen runner, results into the summary. size: a frame's pixels, for
    --jobs auto (None: unknown)."""

    def entry(r, keys):            # a jobs file's line number where there is one
        return {k: r[k] for k in (*keys, "line") if k != "line" or r.get("line")}

    def collect(r, progress):
        if r.get("skipped"):
            summary.skipped.append(entry(r, ("input", "output")))
        elif r["ok"]:
            summary.done.append(entry(r, ("input", "output", "seconds", "warnings")))
        else:
            summary.failed.append(entry(r, ("input", "reason")))
        progress.update(r)

    if jobs == "auto":
        jobs = auto_jobs(total, size)
    progress = Progress(total, quiet)
    source = Source(items, lambda r: collect(r, progress), stream)
    try:
        if scheduler:
            _dask(source, cfg, tuple(aovs), device, scheduler, progress, collect)
        else:
            _local(source, cfg, tuple(aovs), device, jobs, progress, collect)
    finally:
        progress.close()


def run_batch(input_dir: Path, output_dir: Path, cfg, *, depth_pattern=None, recursive=False, fmt=None,
              jobs="auto", skip_existing=False, scheduler=None, aovs=(), device=None, quiet=False,
              report: Path | None = None, layer=None, view=None, save_depth: Path | None = None,
              drop_channels: bool = False) -> Summary:
    t0 = time.perf_counter()
    if aovs and (fmt or "exr").lower().lstrip(".") != "exr":
        raise UserError(f"--aov needs EXR outputs, got --format {fmt}")
    if aovs:
        fmt = "exr"
    if save_depth is not None and save_depth.resolve() == output_dir.resolve():
        raise UserError(f"--save-depth {save_depth}: use a folder other than OUTPUT_DIR (it holds only outputs)")
    plan = discover(input_dir, output_dir, depth_pattern, recursive, fmt, skip_existing, layer, view, save_depth,
                    drop_channels)
    check_side_outputs(plan, report, input_dir, recursive, output_dir)
    output_dir.mkdir(parents=True, exist_ok=True)
    if save_depth is not None:
        save_depth.mkdir(parents=True, exist_ok=True)
    remove_stale_temporaries(output_dir)
    summary = Summary(skipped=[{"input": i, "output": o} for i, o in plan.skipped],
                      failed=[{"input": i, "reason": r} for i, r in plan.failed])
    _run(plan.jobs, False, len(plan.jobs), cfg, aovs, device, jobs, scheduler, quiet, summary,
         size=frame_pixels(plan.jobs[0].input) if plan.jobs and jobs == "auto" else None)
    # a worker killed mid-write (a crash of another frame breaks the whole pool) leaves its
    # temporary file; every worker has stopped now
    remove_stale_temporaries(output_dir)
    summary.seconds = round(time.perf_counter() - t0, 3)
    write_report(report, summary)
    return summary


def run_jobs_file(path: str, *, medium=None, configs=(), sets=(), camera=None, jobs="auto", skip_existing=False,
                  scheduler=None, aovs=(), device=None, quiet=False, report: Path | None = None, layer=None,
                  view=None, drop_channels: bool = False, protected=()) -> Summary:
    """`fogcli batch --jobs-file PATH` (`-`: standard input, taken line by line as it comes)."""
    from fogcli.batch.jobs_file import Parser, count_lines

    t0 = time.perf_counter()
    if report is not None:
        check_report(report, {Path(p).resolve() for p in (*protected, path) if p != "-"})
    parser = Parser(path, medium, configs, sets, camera, aovs=aovs, layer=layer, view=view,
                    drop_channels=drop_channels, protected=protected)
    summary = Summary()
    _run(parser.results(skip_existing), path == "-", count_lines(path), None, aovs, device, jobs, scheduler, quiet,
         summary)
    for part in (summary.done, summary.skipped, summary.failed):     # in the file's order
        part.sort(key=lambda r: int(r["line"].rpartition(":")[2]) if r.get("line") else 0)
    summary.seconds = round(time.perf_counter() - t0, 3)
    write_report(report, summary)
    return summary
