"""Peak resident memory of a command in a process of its own, as `/usr/bin/time` reports it.

A child forked from a large process (pytest, a benchmark that imported fogcli) starts with
the parent's pages counted as its own, and its ru_maxrss keeps that count across exec: a
small launcher (a fresh Python, ~10 MB) forks the command instead and reports the command's
own rusage."""
from __future__ import annotations

import json
import subprocess
import sys

_LAUNCHER = """
import json, os, subprocess, sys, time
t = time.perf_counter()
p = subprocess.Popen(sys.argv[1:], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
err = p.stderr.read()
_, status, ru = os.wait4(p.pid, 0)
print(json.dumps({"code": os.waitstatus_to_exitcode(status), "maxrss": ru.ru_maxrss * 1024,
                  "wall": time.perf_counter() - t, "cpu": ru.ru_utime + ru.ru_stime,
                  "stderr": err.decode(errors="replace")}))
"""


def run_measured(cmd: list, env: dict | None = None) -> dict:
    """{code, maxrss (bytes), wall (s, from the launcher), cpu (s), stderr} of cmd."""
    r = subprocess.run([sys.executable, "-c", _LAUNCHER, *map(str, cmd)], capture_output=True, text=True,
                       env=env, check=True)
    return json.loads(r.stdout)
