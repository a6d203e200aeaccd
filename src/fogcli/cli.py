"""The command line (SPEC 2). Errors are one line on stderr: exit 2 for bad usage or
input, 1 when processing failed. FOGCLI_DEBUG=1 shows tracebacks."""
from __future__ import annotations

import functools
import json
import os
import sys
import time
from pathlib import Path

import click

from . import __version__
from .errors import ProcessingError, UserError
from .pipeline import AOV_NAMES


def _fail(msg: str, code: int):
    click.echo(f"fogcli: {msg}", err=True)
    sys.exit(code)


def guarded(fn):
    @functools.wraps(fn)
    def wrapper(*a, **kw):
        try:
            return fn(*a, **kw)
        except (UserError, ProcessingError) as exc:
            _fail(str(exc), exc.exit_code)
        except KeyboardInterrupt:
            _fail("interrupted", 130)
        except Exception as exc:  # one line, never a traceback, unless asked
            if os.environ.get("FOGCLI_DEBUG"):
                raise
            _fail(f"processing failed: {exc.__class__.__name__}: {exc}", 1)
    return wrapper


@click.group(context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="fogcli")
def main():
    """Add fog, haze, sea water or smoke to images that carry a depth map."""


@main.command()
@click.argument("input", metavar="INPUT")
@click.option("--depth", "depth_path", metavar="DEPTH", help="Depth file (EXR/TIFF/PNG16/NPY); default: the input's Z channel.")
@click.option("--medium", metavar="NAME|FILE", help="Medium preset (see `fogcli media`) or YAML file. Default: fog.")
@click.option("--config", "config_file", metavar="FILE", help="YAML config with any of medium/camera/render/output.")
@click.option("--set", "sets", multiple=True, metavar="KEY=VALUE", help="Override one dotted key, e.g. render.kernel=6.")
@click.option("-o", "--output", metavar="OUTPUT", help="Output file; format from the extension. Default: INPUT.fog.<ext>.")
@click.option("--aov", "aovs", multiple=True, type=click.Choice(AOV_NAMES), help="Extra EXR channels.")
@click.option("--device", metavar="SPEC", help="OpenCL device (P:D, cpu, gpu or a name); env FOGCLI_DEVICE.")
@click.option("--timings", is_flag=True, help="Print a JSON line of stage times on stderr.")
@guarded
def apply(input, depth_path, medium, config_file, sets, output, aovs, device, timings):
    """Apply a medium to INPUT."""
    from . import depth as depth_mod
    from . import inputs, outputs
    from .media import assemble
    from .pipeline import Timings, kernel_ms, run

    start = time.perf_counter()
    cfg = assemble(medium, config_file, sets)
    src = Path(input)
    out_path = Path(output) if output else src.with_name(f"{src.stem}.fog{src.suffix if src.suffix.lower() in outputs.LINEAR_EXT | outputs.DISPLAY_EXT else '.exr'}")
    outputs.check_target(out_path, src, Path(depth_path) if depth_path else None)
    aovs = tuple(dict.fromkeys(aovs))
    if aovs and out_path.suffix.lower() != ".exr":
        raise UserError(f"--aov needs an .exr output, got {out_path.name}")

    io_s = time.perf_counter()
    frame = inputs.read_image(src)
    if depth_path:
        raw_depth = inputs.read_depth(depth_path)
        dsrc = depth_path
    elif frame.depth is not None:
        raw_depth, dsrc = frame.depth, f"{src} (Z channel)"
    else:
        raise UserError(f"{src}: no depth channel (Z, *.Z or *depth); pass --depth FILE")
    io_ms = (time.perf_counter() - io_s) * 1e3
    h, w = frame.rgb.shape[:2]
    if raw_depth.shape != (h, w):
        raise UserError(f"{dsrc}: depth is {raw_depth.shape[1]}x{raw_depth.shape[0]}, the image is {w}x{h}; they must match")
    clean, n_bad = depth_mod.clean(raw_depth, str(dsrc))
    if n_bad:
        click.echo(f"fogcli: warning: {dsrc}: {n_bad} invalid depth pixel(s) (NaN or <= 0) filled from neighbours", err=True)

    t = Timings()
    rgb, planes = run(frame.rgb, clean, cfg, alpha=frame.alpha, aovs=aovs, device=device, timings=t)
    io_s = time.perf_counter()
    outputs.write(out_path, rgb, frame.alpha, planes, frame, cfg.output.half, cfg.output.exposure)
    io_ms += (time.perf_counter() - io_s) * 1e3

    if timings:
        from .runtime import get_runtime

        stages, kms = kernel_ms(t)
        report = {"stages": {k: round(v, 3) for k, v in stages.items()}, "kernel_ms": round(kms, 3),
                  "io_ms": round(io_ms, 3), "total_ms": round((time.perf_counter() - start) * 1e3, 3),
                  "device": get_runtime(device).info.label(), "pixels": w * h}
        click.echo(json.dumps(report), err=True)


@main.command()
@guarded
def devices():
    """List OpenCL platforms and devices, marking the default."""
    from .runtime import choose, list_devices

    devs = list_devices()
    env = os.environ.get("FOGCLI_DEVICE")
    default, _ = choose(devs, env, "FOGCLI_DEVICE")
    for info, dev in devs:
        mark = "*" if info == default else " "
        mem = dev.global_mem_size / 2**30
        click.echo(f"{mark} {info.spec}  {info.kind:<4} {info.name}  [{info.platform}; {info.version}; "
                   f"{dev.max_compute_units} units, {mem:.1f} GiB]")
    click.echo(f"default: {default.spec} {default.name}" + (f" (from FOGCLI_DEVICE={env})" if env else ""))


@main.command()
def media():
    """List the bundled medium presets."""
    from .media import assemble, describe, presets

    for name, path in presets().items():
        m = assemble(name).medium
        sa = ", ".join(f"{x:.4g}" for x in m.absorption)
        ss = ", ".join(f"{x:.4g}" for x in m.scattering)
        click.echo(f"{name:<10} {describe(path)}")
        click.echo(f"{'':<10} absorption [{sa}]  scattering [{ss}]  g {m.asymmetry:g}")


@main.command()
@click.argument("files", nargs=-1, required=True)
def check(files):
    """Validate config files; report every problem with its line."""
    from .media import check_file

    bad = 0
    for f in files:
        problems = check_file(f)
        for p in problems:
            click.echo(p if p.startswith(str(f)) else f"{f}: {p}", err=True)
        if not problems:
            click.echo(f"{f}: ok")
        bad += bool(problems)
    sys.exit(2 if bad else 0)


if __name__ == "__main__":
    main()
