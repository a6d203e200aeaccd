"""How much memory a frame needs and may have: an estimate from the image's header (the
device buffers as plan.BUFFERS declares them, and the host's arrays), the limit the
config sets (limits.memory), and the refusal of an image beyond it before any pixel is
read, with the numbers in the message."""
from __future__ import annotations

from fogcli.errors import UserError

DEFAULT_SHARE = 0.60        # limits.memory: auto
# Host arrays of a frame beyond the file's pixels as read: those pixels widened to float32
# (while the colour, alpha and depth are taken from them), the colour (12 bytes), the raw and
# the cleaned depth (4 + 4): what load() holds at most, and more than compute() and store()
# hold beside the device buffers.
HOST_BYTES_PER_PIXEL = 20


def available_bytes() -> int:
    """Memory this process may still take: MemAvailable, and below a cgroup's (v2) limit."""
    with open("/proc/meminfo") as f:
        avail = next(int(ln.split()[1]) * 1024 for ln in f if ln.startswith("MemAvailable:"))
    try:
        with open("/sys/fs/cgroup/memory.max") as f:
            top = f.read().strip()
        if top != "max":
            with open("/sys/fs/cgroup/memory.current") as f:
                avail = min(avail, int(top) - int(f.read()))
    except (OSError, ValueError):
        pass
    return avail


def limit_bytes(setting) -> int | None:
    """limits.memory in bytes (a size as it is, auto and a share of the memory available
    now); None where the memory available cannot be read (not Linux)."""
    if isinstance(setting, int):
        return setting
    share = DEFAULT_SHARE if setting == "auto" else float(str(setting).strip()[:-1]) / 100.0
    try:
        return int(share * available_bytes())
    except (OSError, StopIteration, ValueError):
        return None


def estimate(width: int, height: int, channels: int, itemsize: int, cfg, aovs=()) -> int:
    """Bytes one frame of this size needs at most: the device buffers its plan declares (and
    what the frame may add to them: plan.planned_bytes) and the host's arrays (the file's
    `channels` as read, `itemsize` bytes each, and HOST_BYTES_PER_PIXEL)."""
    from fogcli.device.plan import level_sizes, plan_features, planned_bytes

    n = width * height
    total = sum(w * h for w, h in level_sizes(width, height, cfg.render.levels))
    device = planned_bytes(n, total, plan_features(cfg, aovs), cfg, height)
    host = n * (channels * (itemsize + 4) + HOST_BYTES_PER_PIXEL)
    return device + host


def admit(source: str, width: int, height: int, channels: int, itemsize: int, cfg, aovs=(), views: int = 1) -> None:
    """UserError when a frame of this size would need more than limits.memory allows.
    views: a multi-view frame's views are held together (one device plan, the host's
    arrays of each)."""
    limit = limit_bytes(cfg.limits.memory)
    if limit is None:
        return
    need = estimate(width, height, channels, itemsize, cfg, aovs)
    need += (views - 1) * width * height * (channels * (itemsize + 4) + HOST_BYTES_PER_PIXEL)
    if need > limit:
        setting = cfg.limits.memory
        what = (f": auto, {DEFAULT_SHARE:.0%} of the memory available" if setting == "auto" else
                f": {setting} of the memory available" if isinstance(setting, str) else "")
        of = f" ({views} views)" if views > 1 else ""
        raise UserError(f"{source}: {width}x{height}{of} needs about {_gib(need)} of memory, more than limits.memory "
                        f"allows ({_gib(limit)}{what}); set limits.memory (e.g. --set limits.memory=90%) "
                        "or use a smaller image")


def _gib(n: int) -> str:
    return f"{n / 2**30:.2f} GiB" if n < 10 * 2**30 else f"{n / 2**30:.0f} GiB"

