"""Writing outputs: scene-linear EXR (float or half, with AOV channels, metadata and both
windows kept) or display-referred sRGB PNG/TIFF/JPEG. Written to a temporary name in the
target folder and renamed, so a reader never sees a partial file."""
from __future__ import annotations

import os
import stat
import tempfile
import threading
from pathlib import Path

import numpy as np

from fogcli.io import openimageio
from fogcli.io.colour import codes, linear_to_srgb
from fogcli.errors import ProcessingError, UserError

DISPLAY_EXT = {".png", ".tif", ".tiff", ".jpg", ".jpeg"}
LINEAR_EXT = {".exr", ".hdr"}
# Attributes that describe the old file's encoding, not the picture.
_DROP = ("compression", "oiio:", "openexr:chunkCount", "openexr:lineOrder", "tiff:", "png:",
         "jpeg:", "planarconfig", "Orientation", "PixelAspectRatio", "XResolution",
         "YResolution", "ResolutionUnit")


def default_ext(source: Path) -> str:
    """The output format when none is asked for: the input's own, else EXR (camera RAW)."""
    ext = source.suffix.lower()
    return ext if ext in DISPLAY_EXT | LINEAR_EXT else ".exr"


def refuse_overwrite(target: Path, option: str, *protected: Path | None, what: str = "the input file") -> None:
    """No output may replace an input (or another output), whether or not either exists
    yet: UserError naming the option."""
    for p in protected:
        if p is not None and os.path.realpath(target) == os.path.realpath(p):
            raise UserError(f"{option} {target}: refusing to overwrite {what}")


def check_target(output: Path, *inputs: Path | None) -> None:
    ext = output.suffix.lower()
    if output.is_dir():
        raise UserError(f"-o {output}: is a folder; give a file name")
    if ext not in DISPLAY_EXT | LINEAR_EXT:
        raise UserError(f"-o {output}: unsupported output format {ext or '(none)'} (use .exr, .hdr, .png, .tif, .jpg)")
    refuse_overwrite(output, "-o", *inputs, what="an input file")
    if not output.parent.exists():
        raise UserError(f"-o {output}: folder {output.parent} does not exist")
    if not os.access(output.parent, os.W_OK | os.X_OK):
        raise UserError(f"-o {output}: folder {output.parent} is not writable")
    if len(output.name.encode()) > 255:
        raise UserError(f"-o {output.name[:40]}...: file name longer than 255 bytes")


def _write_bytes(tmp: str, buf) -> None:
    with open(tmp, "wb") as f:
        f.write(memoryview(buf))
        f.flush()
        os.fsync(f.fileno())


def _hold(path: Path) -> int | None:
    """An open descriptor of the regular file at path, or None. Replacing a file frees its
    blocks in the rename itself (6 MB written a moment ago: 6 ms on ext4); held open, they
    are freed when it is closed, which atomic_write leaves to a thread (in a process of its
    own: at exit, as before)."""
    try:
        fd = os.open(path, os.O_RDONLY | getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_NONBLOCK", 0))
    except OSError:
        return None
    try:
        if stat.S_ISREG(os.fstat(fd).st_mode):
            return fd
    except OSError:
        pass
    os.close(fd)
    return None


def _close_later(fd: int) -> None:
    try:
        threading.Thread(target=os.close, args=(fd,), daemon=True).start()
    except RuntimeError:        # no thread to be had: close it here
        os.close(fd)


def atomic_write(path: Path, write) -> None:
    if len(path.name.encode()) > 255:
        raise UserError(f"{path.name[:40]}...: file name longer than 255 bytes")
    # the stem is cut so that the temporary name stays within 255 bytes however long the name
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{path.stem[:60]}.", suffix=f".tmp{path.suffix[:16]}", dir=path.parent)
    except OSError as exc:
        raise UserError(f"{path}: cannot write into {path.parent} ({exc.strerror})") from None
    os.close(fd)
    try:
        write(tmp)
        # mkstemp makes the file 0600; give the output the permissions a plain open() would
        mask = os.umask(0)
        os.umask(mask)
        os.chmod(tmp, 0o666 & ~mask)
        old = _hold(path)
        try:
            os.replace(tmp, path)
        finally:
            if old is not None:
                _close_later(old)
    except BaseException as exc:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        if isinstance(exc, OSError):
            raise ProcessingError(f"{path}: cannot write ({exc.strerror or exc})") from None
        raise


def is_partial(name: str) -> bool:
    """A temporary file of atomic_write (a killed run may leave one behind)."""
    return name.startswith(".") and ".tmp" in name


def output_is_whole(path: Path) -> bool:
    """An output of a previous run that can be read back entirely (--skip-existing)."""
    oiio = openimageio.load()

    from fogcli.io.quiet import quiet_stderr

    if not path.is_file() or path.stat().st_size == 0:
        return False
    with quiet_stderr():        # libpng prints "IDAT: Read error" on a truncated file itself
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


def write_plane(path: Path, plane: np.ndarray, channel: str) -> None:
    """One float channel (EXR / TIFF), e.g. the cleaned depth."""
    oiio = openimageio.load()

    h, w = plane.shape
    spec = oiio.ImageSpec(w, h, 1, "float")
    spec.channelnames = (channel,)
    data = np.ascontiguousarray(plane, np.float32)[:, :, None]

    def _write(tmp):
        out = oiio.ImageOutput.create(tmp)
        if out is None or not out.open(tmp, spec) or not out.write_image(data):
            raise ProcessingError(f"{path}: cannot write ({oiio.geterror().strip() or 'write failed'})")
        out.close()

    atomic_write(path, _write)


def write(path: Path, rgb: np.ndarray, alpha: np.ndarray | None, aovs: dict, frame, out_type: str = "auto",
          exposure: float = 0.0, compression: str = "auto", drop_channels: bool = False, others=()) -> None:
    """rgb (h, w, 3) scene-linear; aovs: channel name -> (h, w) array. An EXR input to an
    EXR output keeps everything fogcli does not produce (exr.write_passthrough) unless
    drop_channels; others: (frame, rgb, alpha, aovs) of the input's other views, replaced
    there too. out_type auto: the input colour's pixel type where it was half or float
    (EXR), else float; compression auto: the input EXR's, else zip."""
    ext = path.suffix.lower()
    if ext == ".exr" and frame.is_exr and not drop_channels:
        from fogcli.io.exr import write_passthrough

        views = [(frame, rgb, alpha, aovs), *others]
        atomic_write(path, lambda tmp: write_passthrough(path, tmp, views, out_type, compression))
    elif ext in LINEAR_EXT:
        _write_linear(path, rgb, alpha, aovs, frame, out_type, compression)
    else:
        _write_display(path, rgb, alpha, exposure)


def _write_linear(path: Path, rgb: np.ndarray, alpha: np.ndarray | None, aovs: dict, frame, out_type: str,
                  compression: str) -> None:
    """EXR (with alpha and AOVs, the input EXR's window and attributes) or Radiance HDR."""
    oiio = openimageio.load()

    ext = path.suffix.lower()
    h, w = rgb.shape[:2]
    planes = [rgb[:, :, 0], rgb[:, :, 1], rgb[:, :, 2]]
    names = ["R", "G", "B"]
    if alpha is not None and ext == ".exr":     # Radiance HDR holds RGB only
        planes.append(alpha)
        names.append("A")
    if ext == ".exr":
        for name, plane in aovs.items():
            planes.append(plane)
            names.append(name)
    # --drop-channels keeps the input EXR's depth (the job leaves its raw values in the frame)
    z = ext == ".exr" and frame.is_exr and frame.depth is not None and frame.depth.shape == (h, w)
    if z:
        planes.append(frame.depth)
        names.append("Z")
    data = np.ascontiguousarray(np.stack(planes, axis=2), dtype=np.float32)
    if out_type == "auto":
        out_type = frame.pixel_type if frame.is_exr and frame.pixel_type in ("half", "float") else "float"
    fmt = out_type if ext == ".exr" else "float"
    spec = oiio.ImageSpec(w, h, data.shape[2], fmt)
    spec.channelnames = tuple(names)
    if z:       # a depth in half is centimetres off at 20 m
        spec.channelformats = tuple(oiio.TypeDesc(fmt) for _ in names[:-1]) + (oiio.TypeDesc("float"),)
    if "A" in names:
        spec.alpha_channel = 3
    if ext == ".exr":
        spec.x, spec.y = frame.window
        fx, fy, fw, fh = frame.display
        spec.full_x, spec.full_y = fx, fy
        spec.full_width, spec.full_height = (fw or w), (fh or h)
        if frame.is_exr:
            for name, typ, value in frame.attributes:
                if not name.startswith(_DROP) and name not in ("multiView", "view", "name"):
                    try:
                        spec.attribute(name, typ, value)
                    except Exception:
                        pass
        if compression == "auto":
            compression = next((str(v) for n, _, v in frame.attributes if n == "compression"), "zip") \
                if frame.is_exr else "zip"
        spec.attribute("compression", compression)
    spec.attribute("Software", "fogcli")

    def _write(tmp):
        out = oiio.ImageOutput.create(tmp)
        if out is None or not out.open(tmp, spec):
            raise ProcessingError(f"{path}: cannot write ({oiio.geterror().strip() or 'open failed'})")
        ok = out.write_image(data)
        err = out.geterror()
        out.close()
        if not ok:
            raise ProcessingError(f"{path}: cannot write ({err.strip() or 'write failed'})")

    atomic_write(path, _write)


def _write_display(path: Path, rgb: np.ndarray, alpha: np.ndarray | None, exposure: float) -> None:
    """PNG, TIFF (16 bit) or JPEG, sRGB-encoded after the exposure. Encoded in memory (OpenCV)
    and written by Python: a full disk is an error here, where OpenImageIO's PNG writer
    reported success with a truncated file and libjpeg exited the process."""
    import cv2

    ext = path.suffix.lower()
    disp = linear_to_srgb(rgb * np.float32(2.0 ** exposure))
    planes = [disp]
    if alpha is not None and ext not in (".jpg", ".jpeg"):
        planes.append(np.clip(alpha, 0, 1)[:, :, None])
    data = np.concatenate(planes, axis=2)
    top = 65535 if ext in (".tif", ".tiff") else 255
    q = codes(data, top)
    q = np.ascontiguousarray(q[:, :, [2, 1, 0, 3][: q.shape[2]]])     # OpenCV is BGR(A)
    params = [cv2.IMWRITE_JPEG_QUALITY, 95] if ext in (".jpg", ".jpeg") else []
    ok, buf = cv2.imencode(".tiff" if ext == ".tif" else ext, q, params)
    if not ok:
        raise ProcessingError(f"{path}: cannot encode {ext}")
    atomic_write(path, lambda tmp: _write_bytes(tmp, buf))
