"""The `fogcli` command's entry point. With a `fogcli serve` running for this installation,
`fogcli apply` (and `fogcli batch` on one process) hands its command line to it and prints
what it sends back: the server has numpy, OpenCL, the built programs and the device
buffers of the last frame sizes ready, so a frame costs its I/O and kernels, not a new
process's start-up (docs/distributed.md, One command per frame).
With no server running, `fogcli apply` (and `batch --jobs 1`) starts one (autostart) and hands
it its own command.
Anything else, or where no server can run, runs here as usual. This module imports only the
standard library's light parts: it is on every command's path."""
from __future__ import annotations

import os
import sys
import time
import zlib

import _socket      # not socket: its import costs more than all of this module's work

PACKAGE = os.path.dirname(os.path.abspath(__file__))
ENV_PREFIXES = ("FOGCLI_", "POCL_", "PYOPENCL_", "OCL_", "OPENIMAGEIO_", "OIIO_")
ENV_KEYS = ("HOME", "XDG_CACHE_HOME", "LD_LIBRARY_PATH", "LD_PRELOAD", "TMPDIR", "CUDA_VISIBLE_DEVICES")
ENV_ROUTING = ("FOGCLI_SERVER", "FOGCLI_RUN_DIR", "FOGCLI_AUTOSERVE")   # where to send, not how to run: not compared
FORWARDED = ("apply", "batch")
SERVING = False          # set by the server while it runs a client's command
AUTOSERVE_IDLE = 300     # s: how long a server started by `fogcli apply` waits for the next one
START_LIMIT = 15.0       # s: a server that is not ready this long after its start is not waited for
FAILED_PAUSE = 600.0     # s: after a server's start failed, none is started for this long (failed_path)
COLUMNS = 0              # ... and the width of the client's terminal (0: none)


def relevant_env(env=None) -> dict:
    """The variables that change what a run does: a client whose values differ from the
    server's runs on its own."""
    env = os.environ if env is None else env
    return {k: v for k, v in env.items() if (k.startswith(ENV_PREFIXES) or k in ENV_KEYS) and k not in ENV_ROUTING}


def install_key() -> str:
    """This interpreter and these sources: an edited or reinstalled fogcli gets a server of its own."""
    # the interpreter itself (`fogcli` runs as venv/bin/python3, `python -m fogcli` as
    # venv/bin/python: one server for both) and the environment it runs in
    parts = [os.path.realpath(sys.executable), sys.prefix, PACKAGE, sys.version]
    for d in (PACKAGE, os.path.join(PACKAGE, "kernels")):
        try:
            entries = sorted(os.scandir(d), key=lambda e: e.name)
        except OSError:
            continue
        for e in entries:
            if e.name.endswith((".py", ".cl", ".h")) and e.is_file():
                st = e.stat()
                parts.append(f"{e.name}:{st.st_mtime_ns}:{st.st_size}")
    text = "\0".join(parts).encode()
    return f"{zlib.crc32(text):08x}{zlib.adler32(text[::-1]):08x}"


def cache_dir() -> str:
    """fogcli's folder of the user's cache: compiled kernels (runtime.py), the heap record
    (hostmem.py), and the server's sockets where there is no runtime dir."""
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return os.path.join(base, "fogcli")


def run_dir() -> str:
    """A folder only this user can enter (sockets in it need no other protection)."""
    d = os.environ.get("FOGCLI_RUN_DIR")
    if not d:
        base = os.environ.get("XDG_RUNTIME_DIR")
        if not base or not os.path.isdir(base):
            base = cache_dir()
        d = os.path.join(base, "fogcli-run")
    return os.path.abspath(d)       # the same folder for a server that runs in /


def socket_path(key: str | None = None) -> str:
    return os.path.join(run_dir(), f"serve-{key or install_key()}.sock")


def lock_path(key: str | None = None) -> str:
    """Held (flock) by a server from before its start to its exit: one server per
    installation, and clients know one is starting."""
    return os.path.join(run_dir(), f"serve-{key or install_key()}.lock")


def failed_path(key: str | None = None) -> str:
    """Left when a server that `fogcli apply` started died before it was ready (a broken
    installation, a missing library): no other is started for FAILED_PAUSE seconds, so that
    every command does not pay for a start that fails."""
    return os.path.join(run_dir(), f"serve-{key or install_key()}.failed")


def autoserve_idle() -> float:
    """Seconds of idleness after which a server that `fogcli apply` started stops; 0: start
    none (FOGCLI_AUTOSERVE=0, or FOGCLI_SERVER=0: no server at all). ValueError: not a number
    of seconds."""
    if os.environ.get("FOGCLI_SERVER") == "0":
        return 0.0
    v = os.environ.get("FOGCLI_AUTOSERVE", "").strip()
    if not v:
        return float(AUTOSERVE_IDLE)
    try:
        idle = float(v)
    except ValueError:
        idle = -1.0
    if idle != 0 and not 1 <= idle <= 86400:
        raise ValueError(f"FOGCLI_AUTOSERVE: expected the seconds an automatic server waits for the next "
                         f"command (1 to 86400; 0: never start one), got {v!r}")
    return idle


def private_dir(d: str) -> bool:
    try:
        st = os.stat(d)
    except OSError:
        return False
    return st.st_uid == os.getuid() and not st.st_mode & 0o077


# frames: a tag byte and a 4-byte length; client -> server one request (q), server -> client
# o (stdout text), e (stderr text), x (exit code), d (declined: run it yourself)
def send(sock, tag: bytes, payload: bytes) -> None:
    sock.sendall(tag + len(payload).to_bytes(4, "little") + payload)


def recv(sock) -> tuple[bytes, bytes] | None:
    head = _exactly(sock, 5)
    if head is None:
        return None
    body = _exactly(sock, int.from_bytes(head[1:], "little"))
    return None if body is None else (head[:1], body)


def encode_request(argv: list[str], cwd: str, umask: int, env: dict, tty: tuple = (False, False, 0)) -> bytes:
    """NUL-separated (no argument, path or variable can hold a NUL): umask, cwd, the
    terminal (stdout and stderr a terminal, its columns), the argument count, the
    arguments, then the variables as NAME=value."""
    term = f"{int(bool(tty[0]))}{int(bool(tty[1]))}:{int(tty[2])}"
    return "\0".join([str(umask), cwd, term, str(len(argv)), *argv,
                      *(f"{k}={v}" for k, v in sorted(env.items()))]).encode("utf-8", "surrogateescape")


def decode_request(data: bytes) -> dict:
    f = data.decode("utf-8", "surrogateescape").split("\0")
    n = int(f[3])
    if n < 0 or len(f) < 4 + n or len(f[2]) < 4 or f[2][2] != ":" or not set(f[2][:2]) <= {"0", "1"} \
            or not f[2][3:].isdigit():
        raise ValueError("bad request")
    env = dict(kv.split("=", 1) for kv in f[4 + n:] if kv)
    tty = (f[2][0] == "1", f[2][1] == "1", int(f[2][3:]))
    return {"umask": int(f[0]), "cwd": f[1], "tty": tty, "argv": f[4:4 + n], "env": env}


def terminal() -> tuple:
    """(stdout a terminal, stderr a terminal, its columns or 0; $COLUMNS first, as shutil's)."""
    def tty(s) -> bool:
        try:
            return bool(s is not None and s.isatty())
        except (AttributeError, ValueError, OSError):      # closed, or not a file
            return False

    out, err = tty(sys.stdout), tty(sys.stderr)
    cols = os.environ.get("COLUMNS", "")
    if cols.isdigit() and int(cols) > 0:
        return out, err, int(cols)
    try:
        cols = os.get_terminal_size((sys.stderr if err else sys.stdout).fileno()).columns if out or err else 0
    except (AttributeError, OSError, ValueError):
        cols = 0
    return out, err, cols


def served_here(argv: list[str]) -> bool:
    """What the server can run in its own process: apply, and batch on this process
    (--jobs 1, no --scheduler): workers would be processes of their own."""
    if argv[0] != "batch":
        return True
    it = iter(argv[1:])
    for a in it:
        if a == "--scheduler" or a.startswith("--scheduler="):
            return False
        if a == "--jobs" or a.startswith("--jobs="):
            v = a[7:] if a.startswith("--jobs=") else next(it, "")
            try:
                if int(v) != 1:
                    return False
            except ValueError:
                return False    # let click say what is wrong
    return True


def _exactly(sock, n: int) -> bytes | None:
    buf = bytearray()
    while len(buf) < n:
        chunk = sock.recv(min(n - len(buf), 1 << 20))
        if not chunk:
            return None
        buf += chunk
    return bytes(buf)


def forwardable(argv: list[str]) -> bool:
    """A command that a server would run: apply and batch on one process, without reading
    stdin or asking for help, unless FOGCLI_SERVER=0."""
    if os.environ.get("FOGCLI_SERVER") == "0" or not argv or argv[0] not in FORWARDED:
        return False
    return not any(a in ("-", "-h", "--help") for a in argv) and served_here(argv)


def forward(argv: list[str]) -> int | None:
    """The exit code of the command run by the server, or None: run it here."""
    if not forwardable(argv):
        return None
    key = install_key()
    path = socket_path(key)
    if not private_dir(os.path.dirname(path)):
        return None
    if not os.path.exists(path) and not _starting(key, path):
        return None
    sock = _socket.socket(_socket.AF_UNIX, _socket.SOCK_STREAM)
    try:
        sock.connect(path)
    except OSError:          # a server that stopped without cleaning up: nobody listens
        sock.close()
        return None
    mask = os.umask(0)
    os.umask(mask)
    got_any = False
    try:
        send(sock, b"q", encode_request(argv, os.getcwd(), mask, relevant_env(), terminal()))
        while True:
            msg = recv(sock)
            if msg is None:
                break
            tag, body = msg
            if tag == b"d":
                return None
            got_any = True
            if tag == b"x":
                return int(body)
            stream = sys.stdout if tag == b"o" else sys.stderr
            stream.write(body.decode("utf-8", "replace"))
            stream.flush()
    except KeyboardInterrupt:     # closing the socket interrupts the server's run of it
        sys.stderr.write("fogcli: interrupted\n")
        return 130
    except OSError:
        pass
    finally:
        sock.close()
    if not got_any:
        return None
    sys.stderr.write("fogcli: the server (fogcli serve) stopped during the run; run again (FOGCLI_SERVER=0: without it)\n")
    return 1


def _starting(key: str, path: str) -> bool:
    """A server for this installation is starting (its lock is held and was taken lately):
    wait for its socket, as a run here would take longer than the wait, and compete with
    the server's start for the cores. False: none is starting, or it did not get ready."""
    try:
        import fcntl
    except ImportError:
        return False

    deadline = None
    while True:
        try:
            fd = os.open(lock_path(key), os.O_RDONLY | os.O_CLOEXEC)
        except OSError:
            return False
        try:
            try:
                fcntl.flock(fd, fcntl.LOCK_SH | fcntl.LOCK_NB)
                if os.path.exists(path):
                    return True
                # nobody holds it: no server is starting. One that was, died before it was
                # ready if the lock says nothing (the handover) or `<pid> starting`
                # (server._lock_state); `stopped` is a server that ended as it should
                state = os.pread(fd, 64, 0).decode(errors="replace").split()
                if deadline is not None and (not state or state[-1] == "starting"):
                    _touch(failed_path(key))
                return False
            except OSError:
                pass
            if deadline is None:
                deadline = os.fstat(fd).st_mtime + START_LIMIT
        finally:
            os.close(fd)
        if os.path.exists(path):
            return True
        if time.time() > deadline:
            return False
        time.sleep(0.01)


def _touch(path: str) -> None:
    try:
        with open(path, "a"):
            os.utime(path)
    except OSError:
        pass


def autostart(idle: float, env: dict) -> bool:
    """`fogcli apply` found no server: start `fogcli serve --idle <idle>` in a session of its
    own, to run this command and the next ones (forward() then waits for it). The lock is
    taken here and handed down, so that no second client starts another meanwhile. `env`:
    this process's environment as it began. True: started. POSIX only."""
    try:
        import fcntl
        import subprocess
    except ImportError:
        return False
    key = install_key()
    path = socket_path(key)
    d = os.path.dirname(path)
    if not idle or os.name != "posix" or len(os.fsencode(path)) + 12 > 107:
        return False
    try:
        os.makedirs(d, mode=0o700, exist_ok=True)
    except OSError:
        return False
    if not private_dir(d):
        return False
    try:
        if time.time() - os.stat(failed_path(key)).st_mtime < FAILED_PAUSE:
            return False
    except OSError:
        pass
    try:
        fd = os.open(lock_path(key), os.O_RDWR | os.O_CREAT | os.O_CLOEXEC, 0o600)
    except OSError:
        return False
    try:
        # the lock decides, not the socket: a killed server leaves its socket behind, which
        # is removed so that forward() waits for the new one
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        try:
            os.unlink(path)
        except FileNotFoundError:
            pass
        os.ftruncate(fd, 0)     # says nothing until the server writes its state
        os.utime(fd)            # the clients' wait for it counts from now
        env = dict(env, FOGCLI_RUN_DIR=d)      # absolute: the server runs in /
        with open(os.path.join(d, f"serve-{key}.log"), "wb") as log:     # its start-up errors too
            # in /, and with nothing of this process but the lock and its log: no module of
            # the user's folder on its path, no hold on that folder, and a caller reading this
            # command's output (a pipe) sees its end when this process exits. The child runs no
            # Python before exec (PoCL must not be forked into)
            # (`-P` is Python 3.11's; the '' of -c is removed only where it is: PYTHONSAFEPATH)
            boot = ("import sys\nif sys.path and sys.path[0] == '': del sys.path[0]\nsys.argv[0] = 'fogcli'\n"
                    "from fogcli.launch import main\nmain()")
            subprocess.Popen([sys.executable, "-c", boot, "serve", "--idle", f"{idle:g}", "--lock-fd", str(fd),
                              "--key", key],
                             env=env, cwd="/", stdin=subprocess.DEVNULL, stdout=log, stderr=log,
                             close_fds=True, pass_fds=(fd,), start_new_session=True)
        return True
    except (OSError, subprocess.SubprocessError):    # another client holds the lock, or no spawn
        return False
    finally:
        os.close(fd)


def main() -> None:
    argv = sys.argv[1:]
    is_apply = bool(argv) and argv[0] == "apply" and not ({"-h", "--help"} & set(argv))
    try:
        # apply, and batch on this process, start a server when none runs (forwardable)
        idle = autoserve_idle() if bool(argv) and argv[0] in FORWARDED else 0.0
    except ValueError as exc:
        sys.stderr.write(f"fogcli: {exc}\n")
        sys.exit(2)
    try:
        code = forward(argv)
        if code is None and idle and forwardable(argv):
            # no server: start one and hand it this command, so that the next finds it warm
            try:
                started = autostart(idle, dict(os.environ))
            except Exception:  # noqa: BLE001  (a server that cannot start: the command runs here)
                started = False
            if started or os.path.exists(lock_path()):
                code = forward(argv)        # waits for it, or for the one another client started
    except KeyboardInterrupt:       # while waiting for a starting server
        sys.stderr.write("fogcli: interrupted\n")
        sys.exit(130)
    if code is not None:
        sys.exit(code)
    # apply by itself, or the server that `fogcli apply` started (`serve --lock-fd`): the heap
    # the last run held is faulted in on another core while the imports run
    # (hostmem.warm_heap), and what this process held is recorded for the next
    warm = is_apply or (bool(argv) and argv[0] == "serve" and any(a.startswith("--lock-fd") for a in argv))
    if warm:
        from . import hostmem

        hostmem.warm_heap()
    from .cli import main as cli_main

    if warm:
        hostmem.join_warm()
    try:
        cli_main()
    finally:
        if warm:
            hostmem.record_heap()
