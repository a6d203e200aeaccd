"""The command line (README). Errors are one line on stderr: exit 2 for bad usage or
input, 1 when processing failed. FOGCLI_DEBUG=1 shows tracebacks."""
from __future__ import annotations

import errno
import functools
import json
import os
import sys
import time
from pathlib import Path

import click

from fogcli import __version__
from fogcli.errors import ProcessingError, UserError
from fogcli.config.aovs import AOV_NAMES


def _fail(msg: str, code: int):
    click.echo(f"fogcli: {msg}", err=True)
    sys.exit(code)


# Errors of the file system about a path the user gave: bad input (exit 2), one line.
_PATH_ERRNOS = {errno.ENAMETOOLONG, errno.ELOOP, errno.EACCES, errno.EPERM, errno.EROFS, errno.ENOTDIR,
                errno.EISDIR, errno.EEXIST, errno.ENOENT}


def guarded(fn):
    @functools.wraps(fn)
    def wrapper(*a, **kw):
        try:
            _no_empty_paths(kw)
            return fn(*a, **kw)
        except (UserError, ProcessingError) as exc:
            _fail(str(exc), exc.exit_code)
        except KeyboardInterrupt:
            _fail("interrupted", 130)
        except OSError as exc:
            if exc.errno in _PATH_ERRNOS and not os.environ.get("FOGCLI_DEBUG"):
                name = str(exc.filename or "")
                _fail(f"{name[:80] + '...' if len(name) > 80 else name}: {exc.strerror}", 2)
            raise
        except Exception as exc:  # one line, never a traceback, unless asked
            if _interrupted(exc):
                _fail("interrupted", 130)
            if os.environ.get("FOGCLI_DEBUG"):
                raise
            _fail(f"processing failed: {exc.__class__.__name__}: {exc}", 1)
    return wrapper


def _interrupted(exc: BaseException) -> bool:
    """A Ctrl-C that another library caught and wrapped: in the chain of causes, or in
    pydantic's SchemaError, which keeps only the text of what stopped the building of a
    model's validators (a Ctrl-C while the config's models are first imported; fogcli's own
    schemas fail to build for no other reason)."""
    seen, e = set(), exc
    while e is not None and id(e) not in seen:
        if isinstance(e, KeyboardInterrupt):
            return True
        seen.add(id(e))
        e = e.__cause__ or e.__context__
    return type(exc).__name__ == "SchemaError" and "KeyboardInterrupt" in str(exc)


_PATH_OPTIONS = {"input": "INPUT", "depth_path": "--depth", "medium": "--medium", "config_file": "--config",
                 "camera_file": "--camera", "output": "-o", "save_depth": "--save-depth", "report": "--report", "lamps": "--lamps",
                 "input_dir": "INPUT_DIR", "output_dir": "OUTPUT_DIR", "depth_pattern": "--depth-pattern",
                 "jobs_file": "--jobs-file"}


def _no_empty_paths(kw: dict) -> None:
    for key, label in _PATH_OPTIONS.items():
        if kw.get(key) is not None and not str(kw[key]).strip():
            raise UserError(f"{label}: empty; expected a file name")


class _OneLine(click.Group):
    """Usage errors as one line on stderr (exit 2), like every other error."""

    def main(self, *args, **kwargs):
        kwargs["standalone_mode"] = False
        try:
            rv = super().main(*args, **kwargs)
        except click.exceptions.Exit as exc:
            sys.exit(exc.exit_code)
        except click.ClickException as exc:
            if type(exc).__name__ == "NoArgsIsHelpError":      # plain `fogcli`: the help
                click.echo(exc.format_message())
                sys.exit(0)
            ctx = getattr(exc, "ctx", None)
            cmd = f"{ctx.info_name}: " if ctx is not None and ctx.parent is not None else ""
            msg = " ".join(exc.format_message().split())
            click.echo(f"fogcli: {cmd}{msg} (see --help)", err=True)
            sys.exit(exc.exit_code)
        except click.Abort:
            click.echo("fogcli: interrupted", err=True)
            sys.exit(130)
        sys.exit(rv if isinstance(rv, int) else 0)


@click.group(cls=_OneLine, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="fogcli")
def main():
    """Add fog, haze, sea water or smoke to images that carry a depth map."""


def medium_options(fn):
    """Options shared by apply and batch: where the config comes from, the camera file,
    the EXR part to read, AOVs and the device."""
    for opt in reversed([
        click.option("--medium", metavar="NAME|FILE", help="Medium preset (see `fogcli media`) or YAML file. Default: fog."),
        click.option("--config", "config_file", metavar="FILE", help="YAML config with any of medium/camera/render/output."),
        click.option("--camera", "camera_file", metavar="FILE",
                     help="Pinhole intrinsics JSON (Open3D intrinsic_matrix, Cityscapes camera, or fx/fy/cx/cy)."),
        click.option("--set", "sets", multiple=True, metavar="KEY=VALUE", help="Override one dotted key, e.g. render.kernel=6."),
        click.option("--layer", metavar="NAME", help="EXR part or channel layer to read (e.g. ViewLayer.Combined)."),
        click.option("--view", metavar="NAME", help="EXR view to fog (multi-view files; default: every view, each with its own depth)."),
        click.option("--aov", "aovs", multiple=True, type=click.Choice(AOV_NAMES), help="Extra EXR channels."),
        click.option("--drop-channels", is_flag=True,
                     help="EXR: write only R, G, B, (A), the input's depth (Z) and the AOVs, not its other channels, parts and views."),
        click.option("--keep-data-window", is_flag=True,
                     help="EXR: the output's data window is the input's (default: grown to the display window, "
                     "with the light scattered past it); output.data_window=keep."),
        click.option("--device", metavar="SPEC", help="OpenCL device (P:D, cpu, gpu or a name); env FOGCLI_DEVICE."),
    ]):
        fn = opt(fn)
    return fn


def _jobs(value: str):
    """--jobs: 'auto' or a whole number of workers, 1 to 256."""
    if str(value).strip().lower() == "auto":
        return "auto"
    try:
        n = int(str(value).strip())
    except ValueError:
        n = 0
    if not 1 <= n <= 256:
        raise click.BadParameter(f"expected auto or a whole number from 1 to 256, got {value!r}")
    return n


def _window_set(sets: tuple, keep: bool) -> tuple:
    """--keep-data-window is output.data_window=keep (a key: a config or a jobs file's line can say it)."""
    return (*sets, "output.data_window=keep") if keep else sets


@main.command()
@click.argument("input", metavar="INPUT")
@click.option("--depth", "depth_path", metavar="DEPTH", help="Depth file (EXR/TIFF/PNG16/NPY); default: the input's Z channel.")
@medium_options
@click.option("-o", "--output", metavar="OUTPUT", help="Output file; format from the extension. Default: INPUT.fog.<ext>.")
@click.option("--save-depth", metavar="PATH", help="Also write the cleaned metric depth used (EXR/TIFF channel Z, or NPY).")
@click.option("--lamps", metavar="PATH", help="Write the lamps that lights: [{type: auto}] found, as a config "
              "(.json or .yaml) to reuse with --config.")
@click.option("--timings", is_flag=True, help="Print a JSON line of stage times on stderr.")
@guarded
def apply(input, depth_path, medium, config_file, camera_file, sets, layer, view, aovs, drop_channels,
          keep_data_window, device, output, save_depth, lamps, timings):
    """Apply a medium to INPUT."""
    from fogcli.io import outputs
    from fogcli.frame.job import Job, run_job
    from fogcli.config.presets import assemble
    from fogcli.device.plan import Timings
    from fogcli.device.run import kernel_ms

    start = time.perf_counter()
    cfg = assemble(medium, config_file, _window_set(sets, keep_data_window), camera_file)
    src = Path(input)
    out_path = Path(output) if output else src.with_name(f"{src.stem}.fog{outputs.default_ext(src)}")
    # no output replaces any file given as input, config and camera files included (run_job)
    given = tuple(p for p in (config_file, camera_file, medium) if p and Path(p).is_file())
    t = Timings()
    res = run_job(Job(str(src), str(out_path), depth_path, layer, view, save_depth, drop_channels, given, lamps), cfg,
                  aovs=tuple(dict.fromkeys(aovs)), device=device, timings=t)
    for w in res.warnings:
        click.echo(f"fogcli: warning: {w}", err=True)
    if timings:
        from fogcli.device.runtime import get_runtime

        stages, kms = kernel_ms(t)
        report = {"stages": {k: round(v, 3) for k, v in stages.items()}, "kernel_ms": round(kms, 3),
                  "io_ms": round(res.io_ms, 3), "total_ms": round((time.perf_counter() - start) * 1e3, 3),
                  "device": get_runtime(device).info.label(), "pixels": res.pixels}
        click.echo(json.dumps(report), err=True)


@main.command()
@click.argument("input_dir", metavar="[INPUT_DIR", required=False)
@click.argument("output_dir", metavar="OUTPUT_DIR]", required=False)
@click.option("--jobs-file", metavar="FILE", help="One frame a line instead of folders: JSON lines (or CSV with a "
              "header) of input, output and optionally depth, camera, medium, config, set, layer, view, save_depth; "
              "- reads them from standard input as they come.")
@click.option("--depth-pattern", metavar="PATTERN",
              help="Depth file per input, relative to the input's folder: {stem} and #### (frame number), "
                   "e.g. depth/{stem}.png, {stem}_depth.exr, depth.####.exr. Default: the embedded Z.")
@medium_options
@click.option("--format", "fmt", metavar="EXT", help="Output format: exr, png, tif, jpg, hdr. Default: the input's (RAW: exr).")
@click.option("--recursive", is_flag=True, help="Also process sub-folders; outputs keep the folder structure.")
@click.option("--jobs", default="auto", show_default=True, callback=lambda ctx, p, v: _jobs(v), metavar="N|auto",
              help="Worker processes (spawned; each builds its kernels once), 1 to 256; auto: from the cores and "
              "the batch's size (docs/distributed.md).")
@click.option("--skip-existing", is_flag=True, help="Leave outputs that exist and read back whole.")
@click.option("--scheduler", metavar="ADDRESS", help="Run on a Dask cluster: tcp://host:8786, or local:N for a LocalCluster.")
@click.option("--report", metavar="PATH", help="Write the summary (done, skipped, failed with reasons) as JSON.")
@click.option("--save-depth", "save_depth", metavar="DIR",
              help="Also write each frame's cleaned metric depth as DIR/<stem>.exr (channel Z).")
@click.option("-q", "--quiet", is_flag=True, help="No progress output.")
@guarded
def batch(input_dir, output_dir, jobs_file, depth_pattern, medium, config_file, camera_file, sets, layer, view, aovs,
          drop_channels, keep_data_window, device, fmt, recursive, jobs, skip_existing, scheduler, report, save_depth,
          quiet):
    """Apply a medium to every image of INPUT_DIR, writing OUTPUT_DIR/<stem>.<format>; or to
    every line of --jobs-file. Exit 0 when all were written (or skipped), 3 when some failed."""
    from fogcli.batch.progress import describe_failure

    sets = _window_set(sets, keep_data_window)

    given = [Path(p) for p in (config_file, camera_file, medium) if p and Path(p).is_file()]
    if jobs_file is not None:
        s = _batch_jobs_file(jobs_file, input_dir, depth_pattern, fmt, recursive, save_depth, given, medium,
                             config_file, camera_file, sets, layer, view, aovs, drop_channels, device, jobs,
                             skip_existing, scheduler, report, quiet)
    else:
        if input_dir is None or output_dir is None:
            raise UserError("expected INPUT_DIR and OUTPUT_DIR, or --jobs-file FILE")
        from fogcli.batch.runners import run_batch
        from fogcli.config.presets import assemble
        from fogcli.io.outputs import refuse_overwrite

        cfg = assemble(medium, config_file, sets, camera_file)
        if report:
            refuse_overwrite(Path(report), "--report", *given, what="an input file")
        if save_depth and Path(save_depth).exists() and not Path(save_depth).is_dir():
            raise UserError(f"--save-depth {save_depth}: is a file; expected a folder")
        s = run_batch(Path(input_dir), Path(output_dir), cfg, depth_pattern=depth_pattern, recursive=recursive,
                      fmt=fmt, jobs=jobs, skip_existing=skip_existing, layer=layer, view=view, scheduler=scheduler,
                      aovs=aovs, device=device, quiet=quiet, report=Path(report) if report else None,
                      save_depth=Path(save_depth) if save_depth else None, drop_channels=drop_channels)
    for f in s.failed:
        click.echo(f"fogcli: failed: {describe_failure(f)}", err=True)
    if not quiet:
        click.echo(f"fogcli: {len(s.done)} done, {len(s.skipped)} skipped, {len(s.failed)} failed "
                   f"in {s.seconds:.1f} s", err=True)
    sys.exit(3 if s.failed else 0)


def _batch_jobs_file(jobs_file, input_dir, depth_pattern, fmt, recursive, save_depth, given, medium, config_file,
                     camera_file, sets, layer, view, aovs, drop_channels, device, jobs, skip_existing, scheduler,
                     report, quiet):
    """fogcli batch --jobs-file: the folder options have no meaning here; the config
    options are every line's base (checked once, before any line: jobs_file.Parser)."""
    from fogcli.batch.runners import run_jobs_file

    if input_dir is not None:
        raise UserError("--jobs-file takes no INPUT_DIR or OUTPUT_DIR (each line names its files)")
    for name, v in (("--depth-pattern", depth_pattern), ("--format", fmt), ("--save-depth", save_depth),
                    ("--recursive", recursive)):
        if v:
            raise UserError(f"{name} is for folders; with --jobs-file each line says it "
                            "(depth, output's extension, save_depth)")
    if not jobs_file.strip():
        raise UserError("--jobs-file: empty; expected a file name or -")
    return run_jobs_file(jobs_file, medium=medium, configs=(config_file,) if config_file else (), sets=sets,
                         camera=camera_file, jobs=jobs, skip_existing=skip_existing, scheduler=scheduler,
                         aovs=aovs, device=device, quiet=quiet, report=Path(report) if report else None,
                         layer=layer, view=view, drop_channels=drop_channels, protected=tuple(given))


@main.command()
@guarded
def devices():
    """List OpenCL platforms and devices, marking the default."""
    from fogcli.device.runtime import choose, list_devices

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
@click.option("--sheet", metavar="IMAGE", help="Render every preset (and each --config file) on IMAGE as a "
              "labelled contact sheet (-o).")
@click.option("--depth", "depth_path", metavar="DEPTH", help="--sheet: depth file; default: the image's Z channel.")
@click.option("--config", "config_files", multiple=True, metavar="FILE", help="--sheet: also this config, a tile of its own.")
@click.option("--camera", "camera_file", metavar="FILE", help="--sheet: pinhole intrinsics JSON.")
@click.option("-o", "--output", metavar="PNG", help="--sheet: the sheet's file (PNG, JPEG or TIFF).")
@click.option("--set", "sets", multiple=True, metavar="KEY=VALUE", help="--sheet: override a key in every tile "
              "(e.g. camera.depth_scale=0.001).")
@click.option("--width", default=480, show_default=True, type=click.IntRange(64, 4096), help="--sheet: tile width, px.")
@click.option("--device", metavar="SPEC", help="OpenCL device (P:D, cpu, gpu or a name); env FOGCLI_DEVICE.")
@guarded
def media(sheet, depth_path, config_files, camera_file, sets, output, width, device):
    """List the bundled medium presets, or show them all on an image (--sheet)."""
    from fogcli.config.presets import assemble, describe, presets, visibility_m

    if sheet or output:
        if not (sheet and output):
            raise UserError("--sheet IMAGE and -o SHEET go together")
        from fogcli.tune.contact_sheet import contact_sheet

        for w in contact_sheet(sheet, output, depth_path, config_files, camera_file, width, device, sets):
            click.echo(f"fogcli: warning: {w}", err=True)
        return
    for name, path in presets().items():
        m = assemble(name).medium
        sa = ", ".join(f"{x:.4g}" for x in m.absorption)
        ss = ", ".join(f"{x:.4g}" for x in m.scattering)
        vis = m.visibility if isinstance(m.visibility, str) else f"{visibility_m(m):.4g} m"
        dens = "" if [d.type for d in m.density] == ["homogeneous"] else " (at density 1)"
        click.echo(f"{name:<11} {describe(path)}")
        click.echo(f"{'':<11} visibility {vis}{dens}  absorption [{sa}]  scattering [{ss}]  g {m.asymmetry:g}")


@main.command()
@click.argument("image", metavar="IMAGE")
@click.option("--depth", "depth_path", metavar="DEPTH", help="Depth file (EXR/TIFF/PNG16/NPY); default: the image's Z channel.")
@click.option("--medium", metavar="NAME|FILE", help="Medium preset (see `fogcli media`) or YAML file to start from. Default: fog.")
@click.option("--config", "config_file", metavar="FILE", help="YAML config to start from.")
@click.option("--camera", "camera_file", metavar="FILE", help="Pinhole intrinsics JSON.")
@click.option("--set", "sets", multiple=True, metavar="KEY=VALUE", help="Override one dotted key, e.g. "
              "camera.depth_scale=0.001 (kept in the saved YAML).")
@click.option("--port", default=0, type=click.IntRange(0, 65535), help="Port on 127.0.0.1 (default: a free one).")
@click.option("--no-browser", is_flag=True, help="Print the page's address only; do not open a browser.")
@click.option("--device", metavar="SPEC", help="OpenCL device (P:D, cpu, gpu or a name); env FOGCLI_DEVICE.")
@guarded
def tune(image, depth_path, medium, config_file, camera_file, sets, port, no_browser, device):
    """Choose a medium by eye: a page on 127.0.0.1 with IMAGE, in the foreground (Ctrl-C ends it).
    Save writes IMAGE.tune.yaml and IMAGE.fog.<ext>, and prints the `fogcli apply` that makes them."""
    from fogcli.tune.serve import require_server, serve
    from fogcli.tune.session import Session

    require_server()
    session = Session(image, depth_path, medium, config_file, camera_file, device, sets)
    serve(session, port, not no_browser, echo=lambda m: click.echo(m))


@main.command("config")
@click.argument("files", nargs=-1)
@click.option("--show", is_flag=True, help="Print the merged, resolved config as YAML (what the command does; kept "
              "for scripts that say it).")
@click.option("--medium", metavar="NAME|FILE", help="Medium preset or YAML file merged first. Default: fog.")
@click.option("--camera", "camera_file", metavar="FILE", help="Pinhole intrinsics JSON merged after the files.")
@click.option("--set", "sets", multiple=True, metavar="KEY=VALUE", help="Override one dotted key.")
@guarded
def config_cmd(files, show, medium, camera_file, sets):
    """Print the config that apply would use: preset < --medium < FILES (as --config, in
    order) < --camera < --set, validated, with the image-independent auto values resolved."""
    import yaml

    from fogcli.config.validate import resolved_data
    from fogcli.config.presets import assemble

    class Dumper(yaml.SafeDumper):
        pass

    Dumper.add_representer(list, lambda d, v: d.represent_sequence(     # [r, g, b] on one line
        "tag:yaml.org,2002:seq", v, flow_style=not any(isinstance(x, (dict, list)) for x in v)))
    cfg = assemble(medium, list(files), sets, camera_file)
    click.echo(yaml.dump(resolved_data(cfg), Dumper=Dumper, sort_keys=False, width=100), nl=False)


@main.command()
@click.argument("files", nargs=-1, required=True)
@guarded
def check(files):
    """Validate config files; report every problem with its line."""
    from fogcli.config.presets import check_file

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
