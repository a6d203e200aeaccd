"""`fogcli batch`: find the frames of a folder, run them here, in spawned worker processes
or on a Dask cluster, and report. One bad file never stops the batch; outputs are atomic,
so a killed run leaves only whole outputs (and stale temporary files, removed by the next
run), and --skip-existing resumes it."""
from __future__ import annotations

import json
import os
import re
import sys
import tempfile
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path

from .errors import UserError
from .job import Job
from .outputs import DISPLAY_EXT, LINEAR_EXT, default_ext, is_partial


def _image_ext() -> set[str]:
    """What a batch takes as a frame: every format fogcli writes, and camera RAW."""
    from .inputs import RAW_EXT

    return DISPLAY_EXT | LINEAR_EXT | RAW_EXT


def _frame_number(stem: str) -> str | None:
    m = re.search(r"(\d+)(?!.*\d)", stem)
    return m.group(1) if m else None


def depth_for(rel: Path, pattern: str) -> Path:
    """The depth path (relative to INPUT_DIR) of the input at `rel` (relative to INPUT_DIR):
    the pattern is relative to the input's own folder; {stem} is the input's stem, a run of
    # (or %0Nd) its frame number (the last digits of the stem), padded."""
    stem = rel.stem
    out = pattern.replace("{stem}", stem)
    frame = _frame_number(stem)
    if re.search(r"#+|%0?\d*d", out):
        if frame is None:
            raise UserError(f"{rel}: --depth-pattern {pattern} needs a frame number, the name has none")
        out = re.sub(r"#+", lambda m: frame.zfill(len(m.group(0))), out)
        out = re.sub(r"%0?(\d*)d", lambda m: frame.zfill(int(m.group(1) or 0)), out)
    return rel.parent / out


def _pattern_regex(pattern: str) -> re.Pattern:
    """Matches the file names a depth pattern produces (to leave depth files out of the inputs)."""
    parts = re.split(r"(\{stem\}|#+|%0?\d*d)", pattern)
    rx = "".join(".+" if p == "{stem}" else r"\d+" if (p.startswith("#") or p.startswith("%")) else re.escape(p)
                 for p in parts)
    return re.compile(f"^(.*/)?{rx}$")


@dataclass
class Plan:
    jobs: list = field(default_factory=list)          # Job
    skipped: list = field(default_factory=list)       # (input, output)
    failed: list = field(default_factory=list)        # (input, reason)


def output_is_whole(path: Path) -> bool:
    """An output of a previous run that can be read back entirely."""
    import OpenImageIO as oiio

    if not path.is_file() or path.stat().st_size == 0:
        return False
    inp = oiio.ImageInput.open(str(path))
    if inp is None:
        oiio.geterror()
        return False
    try:
        spec = inp.spec()
        px = inp.read_image(0, 0, 0, spec.nchannels, "float")
        ok = px is not None and not (hasattr(inp, "has_error") and inp.has_error)
    except Exception:
        ok = False
    inp.close()
    return ok


def _is_file(p: Path) -> bool:
    """is_file that says no to names the system refuses (too long, a loop of links)."""
    try:
        return p.is_file()
    except OSError:
        return False


def discover(input_dir: Path, output_dir: Path, depth_pattern: str | None, recursive: bool,
             fmt: str | None, skip_existing: bool, layer: str | None = None, view: str | None = None,
             depth_dir: Path | None = None, drop_channels: bool = False) -> Plan:
    if not input_dir.is_dir():
        raise UserError(f"{input_dir}: not a folder (INPUT_DIR)")
    if output_dir.exists() and not output_dir.is_dir():
        raise UserError(f"{output_dir}: exists and is not a folder (OUTPUT_DIR)")
    if output_dir.resolve() == input_dir.resolve():
        raise UserError(f"{output_dir}: OUTPUT_DIR must differ from INPUT_DIR (inputs are never overwritten)")
    if fmt is not None:
        fmt = fmt.lower().lstrip(".")
        if f".{fmt}" not in DISPLAY_EXT | LINEAR_EXT:
            raise UserError(f"--format {fmt}: expected one of exr, hdr, png, tif, jpg")
    exts = _image_ext()
    files = sorted(p for p in (input_dir.rglob("*") if recursive else input_dir.glob("*"))
                   if p.is_file() and p.suffix.lower() in exts and not p.name.startswith("."))
    out_res = output_dir.resolve()
    files = [p for p in files if out_res not in p.resolve().parents]   # OUTPUT_DIR inside INPUT_DIR
    rels = [p.relative_to(input_dir) for p in files]
    depth_rx = _pattern_regex(depth_pattern) if depth_pattern else None
    plan = Plan()
    depths: dict[Path, Path | None] = {}
    for rel in rels:
        if depth_pattern:
            try:
                depths[rel] = depth_for(rel, depth_pattern)
            except UserError as exc:
                plan.failed.append((str(input_dir / rel), str(exc)))
                continue
        else:
            depths[rel] = None
    depth_files = {d for d in depths.values() if d is not None}
    for rel, drel in depths.items():
        if rel in depth_files or (depth_rx and depth_rx.match(rel.as_posix())):
            continue                      # a depth map, not a frame
        ext = f".{fmt}" if fmt else default_ext(rel)
        out = output_dir / rel.parent / f"{rel.stem}{ext}"
        src = input_dir / rel
        if skip_existing and output_is_whole(out):
            plan.skipped.append((str(src), str(out)))
            continue
        depth = None
        if drel is not None:
            dpath = input_dir / drel
            depth = str(dpath) if _is_file(dpath) else None   # missing: try the embedded Z
        saved = str(depth_dir / rel.parent / f"{rel.stem}.exr") if depth_dir else None
        plan.jobs.append(Job(str(src), str(out), depth, layer, view, saved, drop_channels))
    if not (plan.jobs or plan.skipped or plan.failed):
        hint = "" if recursive else "; --recursive looks in sub-folders"
        raise UserError(f"{input_dir}: no images found (EXR, HDR, TIFF, PNG, JPEG, camera RAW){hint}")
    names = {}
    for j in plan.jobs:
        if j.output in names:
            raise UserError(f"{j.input} and {names[j.output]} would both write {j.output}; use --format or rename")
        names[j.output] = j.input
    return plan


def remove_stale_temporaries(output_dir: Path) -> int:
    n = 0
    if output_dir.is_dir():
        for p in output_dir.rglob(".*"):
            if p.is_file() and is_partial(p.name):
                p.unlink(missing_ok=True)
                n += 1
    return n


# -- workers ---------------------------------------------------------------------------
_WORKER: dict = {}


def _die_with_parent() -> None:
    """A worker must not outlive a killed batch (it would keep writing into OUTPUT_DIR)."""
    if sys.platform.startswith("linux"):
        import ctypes
        import signal

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
        import OpenImageIO as oiio

        oiio.attribute("threads", threads)
    _WORKER.update(cfg=cfg, aovs=aovs, device=device, started=started)


def process(job: Job, cfg=None, aovs=None, device=None) -> dict:
    """One job; never raises for a bad input: returns {'ok', 'input', 'output', 'reason'}."""
    from .job import run_job

    cfg = cfg if cfg is not None else _WORKER["cfg"]
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
    Path(job.output).parent.mkdir(parents=True, exist_ok=True)
    if job.save_depth:
        Path(job.save_depth).parent.mkdir(parents=True, exist_ok=True)
    return job


def _done(job: Job, res, t0: float) -> dict:
    return {"ok": True, "input": job.input, "output": job.output, "warnings": res.warnings,
            "seconds": round(time.perf_counter() - t0, 3)}


def _attempt(job: Job, fn):
    """(fn(), None), or (None, the failure's report): a bad input never stops a batch."""
    from .errors import ProcessingError

    try:
        return fn(), None
    except (UserError, ProcessingError) as exc:
        return None, {"ok": False, "input": job.input, "output": job.output, "reason": str(exc)}
    except Exception as exc:  # a worker reports, it does not die
        return None, {"ok": False, "input": job.input, "output": job.output,
                      "reason": f"processing failed: {exc.__class__.__name__}: {exc}"}


# --jobs 1: frames being written at once. The EXR write is most of a frame's core time (zip
# of float noise) and runs serially within one file, so one write at a time left a core idle
# while the device waited for it (benchmarks/throughput.py); the pixel budget keeps large
# frames to one (~40 bytes a pixel held per frame being written).
WRITES_IN_FLIGHT, WRITE_BUDGET_PIXELS = 2, 8_000_000


def _overlapped(jobs, cfg, aovs, device, progress, collect) -> None:
    """--jobs 1: while frame n runs on the device (this thread), frame n + 1 is read and its
    depth cleaned and frames n - 1 and n - 2 written (WRITES_IN_FLIGHT), on threads
    (OpenImageIO and numpy release the GIL; OpenCL stays on this thread). Results are
    reported in input order."""
    from concurrent.futures import ThreadPoolExecutor

    from .job import compute, load, store

    def read(job):
        t0 = time.perf_counter()
        st, failed = _attempt(job, lambda: load(_make_folders(job), cfg, aovs))
        return job, t0, st, failed

    def write(job, t0, st):
        res, failed = _attempt(job, lambda: store(st, cfg))
        return failed or _done(job, res, t0)

    with ThreadPoolExecutor(max_workers=1 + WRITES_IN_FLIGHT, thread_name_prefix="fogcli-io") as io:
        ahead = io.submit(read, jobs[0]) if jobs else None
        writing: list = []         # (future, pixels), oldest first
        for i in range(len(jobs)):
            job, t0, st, failed = ahead.result()
            ahead = io.submit(read, jobs[i + 1]) if i + 1 < len(jobs) else None
            if failed is None:
                st, failed = _attempt(job, lambda: compute(st, cfg, aovs, device))
            px = st.rgb.shape[0] * st.rgb.shape[1] if failed is None else 0
            while writing and (len(writing) >= WRITES_IN_FLIGHT or failed is not None
                               or px + sum(n for _, n in writing) > WRITE_BUDGET_PIXELS):
                collect(writing.pop(0)[0].result(), progress)
            if failed is not None:
                collect(failed, progress)
            else:
                writing.append((io.submit(write, job, t0, st), px))
        for w, _ in writing:
            collect(w.result(), progress)


@dataclass
class Summary:
    done: list = field(default_factory=list)
    skipped: list = field(default_factory=list)
    failed: list = field(default_factory=list)
    seconds: float = 0.0

    def as_json(self) -> dict:
        d = asdict(self)
        d["counts"] = {"done": len(self.done), "skipped": len(self.skipped), "failed": len(self.failed)}
        d["images_per_second"] = round(len(self.done) / self.seconds, 3) if self.seconds > 0 else None
        return d


class Progress:
    """tqdm on a terminal; plain lines otherwise; nothing when quiet."""

    def __init__(self, total: int, quiet: bool):
        self.quiet, self.total, self.n, self.t0 = quiet, total, 0, time.perf_counter()
        self.bar = None
        if not quiet and sys.stderr.isatty():
            from tqdm import tqdm

            from . import launch

            # the width of the terminal the bar is drawn on (the client's when served), 100
            # columns where it reports none
            cols = (launch.COLUMNS if launch.SERVING else launch.terminal()[2]) or 100
            self.bar = tqdm(total=total, unit="img", file=sys.stderr, ncols=cols, desc="fogcli")

    def update(self, r: dict) -> None:
        self.n += 1
        if self.quiet:
            return
        if self.bar is not None:
            self.bar.update(1)
            if not r["ok"]:
                self.bar.write(f"fogcli: failed: {r['reason']}", file=sys.stderr)
            return
        dt = time.perf_counter() - self.t0
        rate = self.n / dt if dt > 0 else 0.0
        eta = (self.total - self.n) / rate if rate > 0 else 0.0
        what = f"done {r['output']}" if r["ok"] else f"failed: {r['reason']}"
        print(f"[{self.n}/{self.total}] {what} ({rate:.2f} img/s, ETA {eta:.0f} s)", file=sys.stderr, flush=True)

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()


def _pool(jobs, workers, cfg, aovs, device, threads, progress, collect):
    """Run `jobs` on `workers` spawned processes. Returns (crashed, started but unfinished,
    never started) when a worker died, else (False, [], [])."""
    import multiprocessing as mp
    from concurrent.futures import ProcessPoolExecutor, wait
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
    done: set = set()
    with ProcessPoolExecutor(max_workers=workers, mp_context=ctx, initializer=init_worker,
                             initargs=(cfg, aovs, device, threads, started)) as ex:
        futs = {ex.submit(process, job): job for job in jobs}
        pending = set(futs)
        crashed = False
        while pending and not crashed:
            finished, pending = wait(pending, return_when="FIRST_COMPLETED")
            for f in finished:
                try:
                    r = f.result()
                except BrokenProcessPool:
                    crashed = True
                    continue
                done.add(futs[f].input)
                collect(r, progress)
    if not crashed:
        return False, [], []
    began = set()
    while not started.empty():
        began.add(started.get())
    rest = [j for j in jobs if j.input not in done]
    return True, [j for j in rest if j.input in began], [j for j in rest if j.input not in began]


def _local(jobs, cfg, aovs, device, n_jobs, progress, collect):
    """In this process (--jobs 1), or on spawned workers. A worker that dies takes its
    frame with it, and the pool breaks: the frames it had not started are rerun on a new
    pool; the ones in flight are rerun one at a time, so the frame that kills a worker
    again is known, and reported as failed."""
    if n_jobs <= 1:
        _overlapped(list(jobs), cfg, aovs, device, progress, collect)
        return
    threads = max(1, (os.cpu_count() or 1) // n_jobs)
    todo, suspects = list(jobs), []
    while todo or suspects:
        if suspects:
            job = suspects.pop(0)
            crashed, _, _ = _pool([job], 1, cfg, aovs, device, os.cpu_count() or 1, progress, collect)
            if crashed:
                collect({"ok": False, "input": job.input, "output": job.output,
                         "reason": "the worker process died on this frame (killed or crashed)"}, progress)
            continue
        crashed, inflight, unstarted = _pool(todo, n_jobs, cfg, aovs, device, threads, progress, collect)
        todo, suspects = unstarted, inflight


def _dask(jobs, cfg, aovs, device, scheduler, progress, collect):
    try:
        from dask.distributed import Client, LocalCluster, as_completed
    except ImportError:
        raise UserError("--scheduler needs Dask: pip install 'dask[distributed]'") from None
    cluster = None
    if scheduler.startswith("local"):
        n = scheduler.partition(":")[2] or str(os.cpu_count() or 1)
        if not n.isdigit() or int(n) < 1:
            raise UserError(f"--scheduler {scheduler}: expected local:N with N >= 1 workers")
        import dask

        # workers are spawned (never forked, PoCL hangs in a forked child) and share the
        # cores: each gets cores / N PoCL and OpenImageIO threads, like --jobs N
        threads = str(max(1, (os.cpu_count() or 1) // int(n)))
        dask.config.set({"distributed.worker.multiprocessing-method": "spawn"})
        cluster = LocalCluster(n_workers=int(n), threads_per_worker=1, processes=True,
                               dashboard_address=None, silence_logs=40,
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
        # kernels are built once per worker process by the runtime cache
        futs = [client.submit(process, job, cfg, aovs, device, pure=False, key=f"fogcli-{i}-{job.input}")
                for i, job in enumerate(jobs)]
        for f in as_completed(futs):
            try:
                r = f.result()
            except Exception as exc:   # a worker lost mid-task
                r = {"ok": False, "input": "?", "output": "?", "reason": f"worker failed: {exc}"}
            collect(r, progress)
    finally:
        client.close()
        if cluster is not None:
            cluster.close()


def _check_side_outputs(plan, report: Path | None, input_dir: Path, recursive: bool, output_dir: Path) -> None:
    """--report and --save-depth never replace an input, and fail before any frame is done."""
    inputs = {Path(j.input).resolve() for j in plan.jobs} | {Path(j.depth).resolve() for j in plan.jobs if j.depth}
    exts = _image_ext()
    inputs |= {p.resolve() for p in (input_dir.rglob("*") if recursive else input_dir.glob("*"))
               if p.is_file() and p.suffix.lower() in exts | {".npy", ".yaml", ".json"}}
    if report is not None:
        if os.path.realpath(report) == os.path.realpath(output_dir):
            raise UserError(f"--report {report}: is OUTPUT_DIR; expected a JSON file name")
        if report.resolve() in inputs:
            raise UserError(f"--report {report}: refusing to overwrite an input file")
        if report.is_dir():
            raise UserError(f"--report {report}: is a folder, expected a JSON file name")
        if not report.parent.is_dir():
            raise UserError(f"--report {report}: folder {report.parent} does not exist")
        try:                # writable? (asked before any frame is done, not after)
            tempfile.TemporaryFile(dir=report.parent).close()
        except OSError as exc:
            raise UserError(f"--report {report}: cannot write into {report.parent} ({exc.strerror})") from None
    for j in plan.jobs:
        if j.save_depth and Path(j.save_depth).resolve() in inputs:
            raise UserError(f"--save-depth {Path(j.save_depth).parent}: {Path(j.save_depth).name} would overwrite "
                            "an input; use another folder")


def run_batch(input_dir: Path, output_dir: Path, cfg, *, depth_pattern=None, recursive=False, fmt=None,
              jobs=1, skip_existing=False, scheduler=None, aovs=(), device=None, quiet=False,
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
    _check_side_outputs(plan, report, input_dir, recursive, output_dir)
    output_dir.mkdir(parents=True, exist_ok=True)
    if save_depth is not None:
        save_depth.mkdir(parents=True, exist_ok=True)
    remove_stale_temporaries(output_dir)
    summary = Summary(skipped=[{"input": i, "output": o} for i, o in plan.skipped],
                      failed=[{"input": i, "reason": r} for i, r in plan.failed])

    def collect(r, progress):
        if r["ok"]:
            summary.done.append({k: r[k] for k in ("input", "output", "seconds", "warnings")})
        else:
            summary.failed.append({"input": r["input"], "reason": r["reason"]})
        progress.update(r)

    progress = Progress(len(plan.jobs), quiet)
    try:
        if scheduler:
            _dask(plan.jobs, cfg, tuple(aovs), device, scheduler, progress, collect)
        else:
            _local(plan.jobs, cfg, tuple(aovs), device, jobs, progress, collect)
    finally:
        progress.close()
    # a worker killed mid-write (a crash of another frame breaks the whole pool) leaves its
    # temporary file; every worker has stopped now
    remove_stale_temporaries(output_dir)
    summary.seconds = round(time.perf_counter() - t0, 3)
    if report:
        from .outputs import atomic_write

        text = json.dumps(summary.as_json(), indent=2)
        atomic_write(report, lambda tmp: Path(tmp).write_text(text))
    return summary
