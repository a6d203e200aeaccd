"""`fogcli serve`: one process that keeps numpy, OpenCL, the built programs and the device
buffers of recent frame sizes, and runs the `fogcli apply` and `fogcli batch --jobs 1`
command lines that clients (launch.py) hand it, one at a time, in the client's folder and
with its umask. A client that arrives while a run is going on, or whose environment
differs in what changes a run, is told to run the command itself. A client that goes away
(Ctrl-C, killed) interrupts its run as Ctrl-C would: the output's temporary file is
removed. No fork: the runs happen in this process (PoCL must not be forked)."""
from __future__ import annotations

import io
import os
import queue
import signal
import socket
import sys
import threading
import time
import warnings

from . import launch
from .errors import UserError
from .hostmem import keep_freed_memory

# The watcher's interrupt of a run whose client went away: a real signal, so that a run
# blocked on a lock (a batch waiting for its read or write) returns at once to raise it
# (interrupt_main only sets a flag, seen when the wait ends). Not SIGINT (that stops the
# server), not SIGUSR1 (PoCL installs its own handler for it when it starts).
INTERRUPT = signal.SIGRTMIN + 1 if hasattr(signal, "SIGRTMIN") else signal.SIGUSR2     # macOS has no real-time ones


class _Stream(io.TextIOBase):
    """stdout or stderr of one run: text sent to the client as it is written."""

    def __init__(self, conn: socket.socket, tag: bytes, tty: bool = False, lock: threading.Lock | None = None):
        self.conn, self.tag, self.tty = conn, tag, tty
        self.lock = lock or threading.Lock()    # shared by a run's two streams: one frame at a time

    def write(self, s: str) -> int:
        try:
            with self.lock:     # tqdm's monitor thread writes too
                launch.send(self.conn, self.tag, s.encode("utf-8", "replace"))
        except OSError:
            pass       # the client is gone; the watcher interrupts the run
        return len(s)

    def isatty(self) -> bool:
        return self.tty         # the client's: progress bars as on a run of its own

    @property
    def encoding(self) -> str:
        return "utf-8"


class Server:
    def __init__(self, idle: float, log):
        self.idle, self.log = idle, log
        self.env = launch.relevant_env()       # before the runtime adds POCL_CACHE_DIR
        self.jobs: queue.Queue = queue.Queue()
        self.lock = threading.Lock()
        self.busy = False
        self.running = None                    # the connection whose run is going on
        self.stopping = False                  # Ctrl-C or SIGTERM of the server itself
        self.filters = list(warnings.filters)
        self.saved = None                      # what a run changes: stdout, stderr, folder, umask
        self.on_trial = False                  # started by `fogcli apply`: stop if its command fails

    def waiting(self, seconds: float) -> bool:
        """A command is queued now or within `seconds`."""
        end = time.monotonic() + seconds
        while self.jobs.empty():
            if time.monotonic() > end:
                return False
            time.sleep(0.005)
        return True

    # ------------------------------------------------------------------ acceptor thread
    def accept_loop(self, sock: socket.socket) -> None:
        while True:
            try:
                conn, _ = sock.accept()
            except OSError:
                return
            threading.Thread(target=self._admit, args=(conn,), daemon=True).start()

    def _admit(self, conn: socket.socket) -> None:
        try:
            conn.settimeout(10)
            msg = launch.recv(conn)
            conn.settimeout(None)
            req = launch.decode_request(msg[1]) if msg and msg[0] == b"q" else None
            ok = isinstance(req, dict) and req.get("env") == self.env and isinstance(req.get("argv"), list)
            with self.lock:
                take = ok and not self.busy
                self.busy = self.busy or take
            if take:
                self.jobs.put((conn, req))
                return
            why = "busy" if ok else ("its environment differs (FOGCLI_*, POCL_*, ...)" if isinstance(req, dict)
                                     else "not a request")
            self.log(f"a client runs by itself: {why}")
            launch.send(conn, b"d", b"")
        except (OSError, ValueError, IndexError):
            pass
        conn.close()

    def _watch(self, conn: socket.socket) -> None:
        """EOF from the client while its run is going on: interrupt the run."""
        try:
            while conn.recv(4096):
                pass
        except OSError:
            pass
        with self.lock:
            if self.running is conn:
                self.running = None
                signal.pthread_kill(threading.main_thread().ident, INTERRUPT)

    # ------------------------------------------------------------------ main thread
    def loop(self) -> None:
        last = time.monotonic()
        while not self.stopping:
            try:
                if not self._next(last):
                    return
            except KeyboardInterrupt:
                if self.stopping:
                    raise
            finally:       # again: an interrupt may have cut the run's own clean-up short
                self._restore()
                with self.lock:
                    self.busy = False
                    self.running = None
            last = time.monotonic()
        raise KeyboardInterrupt

    def _restore(self) -> None:
        if self.saved is not None:
            _join_io_threads()      # a batch's writes resolve their paths in the client's folder
            sys.stdout, sys.stderr, cwd, mask = self.saved
            launch.SERVING, launch.COLUMNS = False, 0
            os.umask(mask)
            os.chdir(cwd)
            self.saved = None       # last: an interrupt before this restores again

    def _next(self, last: float) -> bool:
        try:
            conn, req = self.jobs.get(timeout=max(0.1, self.idle - (time.monotonic() - last)))
        except queue.Empty:
            if time.monotonic() - last < self.idle:
                return True
            self.log(f"idle for {self.idle:g} s: stopping")
            return False
        try:
            code = self.run(conn, req)
        finally:
            try:
                conn.shutdown(socket.SHUT_RDWR)     # wakes the watcher's recv
            except OSError:
                pass
            conn.close()
        if self.on_trial:
            # the command of the `fogcli apply` that started it: its heap is the record for the
            # next (later ones count the buffers kept for other sizes too); if it failed (a
            # typo, a bad file, not Ctrl-C), no server
            from . import hostmem

            self.on_trial = False
            if code == 0:
                hostmem.record_heap()
            hostmem.forget()
            if code not in (0, 130):
                self.log(f"the command that started this server ended with exit {code}: stopping")
                return False
        return True

    def run(self, conn: socket.socket, req: dict) -> int:
        from .cli import main as cli_main

        t = time.perf_counter()
        tty = req.get("tty", (False, False, 0))
        one = threading.Lock()
        out, err = _Stream(conn, b"o", tty[0], one), _Stream(conn, b"e", tty[1], one)
        code = 1
        with self.lock:
            self.running = conn
        threading.Thread(target=self._watch, args=(conn,), daemon=True).start()
        try:
            self.saved = sys.stdout, sys.stderr, os.getcwd(), os.umask(int(req.get("umask", 0o022)))
            launch.SERVING, launch.COLUMNS = True, tty[2]
            os.chdir(req["cwd"])
            sys.stdout, sys.stderr = out, err
            with warnings.catch_warnings():      # each run warns anew, as a process of its own
                warnings.filters[:] = self.filters
                cli_main.main(args=[str(a) for a in req["argv"]], prog_name="fogcli")
        except SystemExit as exc:
            code = exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 1)
        except KeyboardInterrupt:
            code = 130
            if self.stopping:
                raise
        except BaseException as exc:  # noqa: BLE001  (a bug must not stop the server)
            err.write(f"fogcli: processing failed: {exc.__class__.__name__}: {exc}\n")
            code = 1
        finally:
            with self.lock:
                self.running = None
            self._restore()
        try:
            launch.send(conn, b"x", str(code).encode())
        except OSError:
            pass
        self.log(f"{' '.join(map(str, req['argv']))[:200]}: exit {code} ({(time.perf_counter() - t) * 1e3:.0f} ms)")
        return code


def _join_io_threads() -> None:
    """A batch's I/O threads (batch._overlapped) finished: an interrupt during the pool's own
    shutdown can leave them writing."""
    for t in threading.enumerate():
        while t.name.startswith("fogcli-io") and t.is_alive():
            try:
                t.join()
            except KeyboardInterrupt:
                continue


def _warm_up(device: str | None) -> None:
    """The default pipeline's programs built before the first client comes."""
    import numpy as np

    from .api import apply, make_config

    apply(np.ones((48, 64, 3), np.float32), np.full((48, 64), 10.0, np.float32), make_config("fog"), device=device)


def stop_running(limit: float = 600.0) -> int | None:
    """`fogcli serve --stop`: SIGTERM to this installation's server, back once it has gone
    (its lock is free). Its pid, or None if none was running."""
    import fcntl

    try:
        fd = os.open(launch.lock_path(), os.O_RDONLY | os.O_CLOEXEC)
    except FileNotFoundError:
        return None
    try:
        end = time.monotonic() + limit
        pid = 0
        while True:
            try:
                fcntl.flock(fd, fcntl.LOCK_SH | fcntl.LOCK_NB)
                return pid or None          # free: it has gone (or none ran)
            except OSError:
                pass
            if not pid:     # a server being handed its lock writes its pid as it starts
                text = os.pread(fd, 64, 0).decode(errors="replace").split()
                if text and text[0].isdigit():
                    pid = int(text[0])
                    try:
                        os.kill(pid, signal.SIGTERM)
                    except ProcessLookupError:
                        pass
            if time.monotonic() > end:
                raise UserError(f"{launch.lock_path()}: the server (pid {pid or '?'}) did not stop within {limit:g} s")
            time.sleep(0.02)
    finally:
        os.close(fd)


def _take_lock(key: str, lock_fd: int | None) -> int:
    """The installation's server lock (launch.lock_path), held until this process exits; a
    server that `fogcli apply` started was handed it already locked."""
    import fcntl

    if lock_fd is not None:
        os.set_inheritable(lock_fd, False)
        fd = lock_fd
    else:
        fd = os.open(launch.lock_path(key), os.O_RDWR | os.O_CREAT | os.O_CLOEXEC, 0o600)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            os.close(fd)
            raise UserError(f"a server for this installation is running already ({launch.socket_path(key)})") from None
    _lock_state(fd, "starting")      # also dates the start: clients wait from here
    return fd


def _lock_state(fd: int, state: str, pid: bool = True) -> None:
    """The lock file's text: this server's pid and where it is (starting, ready; stopped
    without a pid). A lock let go while it says starting (or nothing: the handover) is a
    start that failed (launch._starting)."""
    os.ftruncate(fd, 0)
    os.pwrite(fd, (f"{os.getpid()} {state}\n" if pid else f"{state}\n").encode(), 0)


def serve(idle: float, device: str | None = None, lock_fd: int | None = None, key: str | None = None) -> None:
    if key is not None and key != launch.install_key():
        # started for another copy of fogcli than this interpreter imports (a source folder
        # on the client's path): it would listen where that client does not look
        raise UserError(f"started for the installation {key}, but this is {launch.install_key()}: not serving")
    key = launch.install_key()
    path = launch.socket_path(key)
    d = os.path.dirname(path)
    if len(os.fsencode(path)) + 12 > 107:          # sun_path is 108 bytes, the temporary name adds a pid
        raise UserError(f"{d}: too long a folder for the server's socket; set FOGCLI_RUN_DIR to a shorter one")
    try:
        os.makedirs(d, mode=0o700, exist_ok=True)
    except OSError as exc:
        raise UserError(f"{d}: cannot make the server's folder ({exc.strerror})") from None
    if not launch.private_dir(d):
        raise UserError(f"{d}: must belong to you and be closed to others (chmod 700)")
    lock = _take_lock(key, lock_fd)
    probe = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    probe.settimeout(5)
    try:
        probe.connect(path)
        raise UserError(f"a server for this installation is running already ({path})")
    except OSError:
        pass
    finally:
        probe.close()

    own = sys.stderr       # a run replaces sys.stderr with its client's; the log stays here

    def log(msg: str) -> None:
        own.write(f"fogcli serve: {msg}\n")
        own.flush()

    srv = Server(idle, log)
    srv.on_trial = lock_fd is not None

    def stop(signum, frame):
        srv.stopping = True
        # SIGTERM (`fogcli serve --stop`) lets a run that is going on finish: its client asked
        # for nothing to stop; Ctrl-C of the server itself stops at once
        if signum == signal.SIGINT or srv.running is None:
            raise KeyboardInterrupt

    def client_gone(signum, frame):
        raise KeyboardInterrupt

    signal.signal(signal.SIGINT, stop)
    signal.signal(signal.SIGTERM, stop)
    tmp = f"{path}.{os.getpid()}"
    sock = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    ino = None
    try:
        keep_freed_memory()
        # listening before the warm-up: a client that comes meanwhile waits in the queue
        # rather than starting a process of its own beside it
        sock.bind(tmp)
        sock.listen(16)
        os.replace(tmp, path)        # a stale socket of a killed server is replaced
        ino = os.stat(path).st_ino
        _lock_state(lock, "ready")
        try:
            os.unlink(launch.failed_path(key))      # starts work here again
        except OSError:
            pass
        threading.Thread(target=srv.accept_loop, args=(sock,), daemon=True).start()
        # started by `fogcli apply`, whose command is waiting: its own run is the warm-up
        if not srv.waiting(0.05 if lock_fd is None else 1.0):
            _warm_up(device)
        if srv.stopping:
            raise KeyboardInterrupt
        signal.signal(INTERRUPT, client_gone)     # after PoCL's start-up, in case it takes a handler
        log(f"ready on {path} (stops after {idle:g} s idle; FOGCLI_SERVER=0 runs a command without it)")
        srv.loop()
    except KeyboardInterrupt:
        log("interrupted: stopping")
    finally:
        sock.close()
        try:
            _lock_state(lock, "stopped", pid=False)     # no pid of a gone server left for `fogcli serve --stop`
        except OSError:
            pass
        try:
            if ino is None:
                os.unlink(tmp)
            elif os.stat(path).st_ino == ino:     # not a newer server's socket
                os.unlink(path)
        except OSError:
            pass
