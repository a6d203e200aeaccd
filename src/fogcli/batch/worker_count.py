"""How many worker processes `fogcli batch --jobs auto` starts."""
from __future__ import annotations

import os

from fogcli.io import openimageio

# --jobs auto. One process already keeps a 2-core machine busy (PoCL's threads in the
# kernels, reads and writes on threads beside them: 90-94 % of both cores, tools/throughput.py),
# and spawned workers were slower there, by their start-up on small batches and by as much
# even on 24 frames of 2 MPx (tools/jobs_auto.py). Workers pay off where one process's
# kernels stop scaling with the cores (PoCL: 1.2-1.3x from one thread to two): one worker
# per CORES_PER_WORKER cores, once the batch's work is many times their start-up.
CORES_PER_WORKER = 4
WORKER_START_S = 1.0            # a spawned worker's start-up, kernels from PoCL's cache (2 cores: 0.6-1.0 s)
CORE_S_PER_PIXEL = 3e-7         # a frame's core time (2 MPx EXR: 0.62 core-s, AMD EPYC, tools/jobs_auto.py)


def usable_cores() -> int:
    """The cores this process may run on (its affinity: taskset, a cgroup's cpuset), not the
    machine's, and at most its cgroup's CPU quota (docker --cpus, a Kubernetes limit)."""
    try:
        n = max(1, len(os.sched_getaffinity(0)))
    except (AttributeError, OSError):
        n = os.cpu_count() or 1
    try:
        quota, period = open("/sys/fs/cgroup/cpu.max").read().split()[:2]
        if quota != "max":
            n = min(n, max(1, -(-int(quota) // int(period))))
    except (OSError, ValueError):
        pass
    return n


def auto_jobs(frames: int | None, pixels: int | None, cores: int | None = None) -> int:
    """The worker count of --jobs auto for `frames` frames of about `pixels` each (None:
    unknown, a stream)."""
    cores = cores or usable_cores()
    workers = cores // CORES_PER_WORKER
    if workers < 2 or not frames or not pixels:
        return 1
    work_s = frames * pixels * CORE_S_PER_PIXEL / cores       # what one process would take
    if work_s < 10 * WORKER_START_S:          # workers start side by side
        return 1
    return max(1, min(workers, frames // 4))


def frame_pixels(path: str) -> int | None:
    """A frame's pixel count from its header (None: unreadable; the frame's own error comes later)."""
    try:
        oiio = openimageio.load()

        inp = oiio.ImageInput.open(path)
        if inp is None:
            oiio.geterror()
            return None
        s = inp.spec()
        inp.close()
        return int(s.width) * int(s.height)
    except Exception:
        return None
