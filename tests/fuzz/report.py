"""One run's results: the table of counts per class, the defects and their signatures."""
from __future__ import annotations

import os
import re
import shlex
import shutil
import signal
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

from fuzz.case import Case
from fuzz.files import RSS_KILL_MB, TIMEOUT
from fuzz.judge import _restore_perms, _snapshot, fogcli_command, judge


@dataclass
class Result:
    case: Case
    rc: int | None
    stderr: str
    seconds: float
    rss_mb: float
    kinds: list


def _tree_rss_mb(pid: int) -> float:
    try:
        import psutil

        p = psutil.Process(pid)
        return sum(q.memory_info().rss for q in [p] + p.children(recursive=True)) / 2**20
    except Exception:
        return 0.0


def run_case(case: Case, work: Path, timeout: float = TIMEOUT, keep: bool = False) -> Result:
    folder = work / case.id
    if folder.exists():
        _restore_perms(folder)
        shutil.rmtree(folder)
    folder.mkdir(parents=True)
    if case.setup:
        try:
            case.setup(folder)
        except Exception as exc:          # a generator bug, not a fogcli defect: say so
            return Result(case, None, "", 0.0, 0.0, [f"harness-error:{exc.__class__.__name__}: {exc}"[:200]])
    before = _snapshot(folder)
    io = work / "_io"
    io.mkdir(exist_ok=True)
    env = {k: v for k, v in os.environ.items() if k not in ("FOGCLI_DEBUG", "FOGCLI_DEVICE", "PYTHONWARNINGS")}
    env.update(case.env)
    err_path, out_path = io / f"{case.id}.err", io / f"{case.id}.out"
    t0 = time.perf_counter()
    with open(err_path, "wb") as ferr, open(out_path, "wb") as fout:
        proc = subprocess.Popen(fogcli_command() + case.args, cwd=folder, stdout=fout, stderr=ferr,
                                stdin=subprocess.DEVNULL, env=env, start_new_session=True)
    timed_out, killed_mem, status, ru = False, False, None, None
    last_poll = 0.0
    while True:
        pid, status, ru = os.wait4(proc.pid, os.WNOHANG)
        if pid:
            break
        now = time.perf_counter()
        if now - t0 > timeout:
            timed_out = True
        elif now - last_poll > 0.25:
            last_poll = now
            if _tree_rss_mb(proc.pid) > RSS_KILL_MB:
                killed_mem = True
        if timed_out or killed_mem:
            try:
                os.killpg(proc.pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
            _, status, ru = os.wait4(proc.pid, 0)
            break
        time.sleep(0.01)
    proc.returncode = os.waitstatus_to_exitcode(status)
    try:                                   # whatever the run left in its group (batch workers)
        os.killpg(proc.pid, signal.SIGKILL)
    except (ProcessLookupError, PermissionError):
        pass
    seconds = time.perf_counter() - t0
    rss_mb = ru.ru_maxrss / 1024.0 if ru else 0.0
    if killed_mem:
        rss_mb = max(rss_mb, RSS_KILL_MB + 1)
    stderr = err_path.read_bytes().decode("utf-8", "replace")
    err_path.unlink()
    out_path.unlink()
    after = _snapshot(folder)
    kinds = judge(case, None if timed_out else proc.returncode, stderr, timed_out, before, after, folder, rss_mb)
    if not keep and not kinds:
        _restore_perms(folder)
        shutil.rmtree(folder, ignore_errors=True)
    else:
        _restore_perms(folder)
    return Result(case, None if timed_out else proc.returncode, stderr, seconds, rss_mb, kinds)


def command_line(case: Case) -> str:
    return "fogcli " + shlex.join(case.args)


def signature(res: Result) -> str:
    """A grouping key for distinct defects: the kinds and the gist of the first stderr line."""
    kinds = sorted({k.split(":")[0] for k in res.kinds})
    lines = [ln for ln in res.stderr.splitlines() if ln.strip()]
    gist = ""
    if "Traceback" in res.stderr:
        tail = [ln for ln in lines if re.match(r"^\w[\w.]*(Error|Exception|Interrupt)\b", ln)]
        gist = (tail[-1] if tail else lines[-1])[:80]
    elif lines:
        ln = next((x for x in lines if "processing failed" in x or "Warning" in x), lines[0])
        m = re.search(r"processing failed: (\w+)", ln)
        gist = m.group(0) if m else ln
    gist = re.sub(r"\d+", "N", gist)
    gist = re.sub(r"'[^']*'", "'…'", gist)[:100]
    return f"{'+'.join(kinds)} | {res.case.cls} | {gist}"


COLUMNS = ["cases", "ok", "refused", "exit3", "traceback", "hang", "leftover", "changed", "warning", "bad-exit",
           "bad-msg", "other", "rss_mb"]


def summarise(results: list[Result]) -> dict:
    table: dict[str, dict] = {}
    for res in results:
        row = table.setdefault(res.case.cls, dict.fromkeys(COLUMNS, 0))
        row["cases"] += 1
        row["ok"] += res.rc == 0
        row["refused"] += res.rc == 2
        row["exit3"] += res.rc == 3
        kinds = {k.split(":")[0] for k in res.kinds}
        row["traceback"] += "traceback" in kinds
        row["hang"] += "hang" in kinds
        row["leftover"] += "leftover" in kinds
        row["changed"] += "changed-input" in kinds
        row["warning"] += bool(kinds & {"warning", "stray-stderr"})
        row["bad-exit"] += bool(kinds & {"exit-1", "bad-exit"})
        row["bad-msg"] += "bad-message" in kinds
        row["other"] += bool(kinds - {"traceback", "hang", "leftover", "changed-input", "warning", "stray-stderr",
                                      "exit-1", "bad-exit", "bad-message"})
        row["rss_mb"] = max(row["rss_mb"], round(res.rss_mb))
    total = dict.fromkeys(COLUMNS, 0)
    for row in table.values():
        for c in COLUMNS:
            total[c] = max(total[c], row[c]) if c == "rss_mb" else total[c] + row[c]
    table["TOTAL"] = total
    return table


def print_table(table: dict, file=sys.stdout) -> None:
    w = max(len(k) for k in table) + 2
    print("class".ljust(w) + "".join(c.rjust(10) for c in COLUMNS), file=file)
    for name, row in table.items():
        print(name.ljust(w) + "".join(str(row[c]).rjust(10) for c in COLUMNS), file=file)
    print("(ok: exit 0; refused: exit 2; other: accepted-bad-input, refused-valid-input, bad/nonfinite output, "
          "memory > 4 GB; rss_mb: largest peak RSS of a case)", file=file)


def defect_record(res: Result) -> dict:
    lines = [ln for ln in res.stderr.splitlines() if ln.strip()]
    return {"id": res.case.id, "class": res.case.cls, "variant": res.case.variant, "kinds": res.kinds,
            "command": command_line(res.case), "exit": res.rc, "stderr": [ln[:300] for ln in lines[:6]],
            "stderr_tail": [ln[:300] for ln in lines[-3:]] if len(lines) > 6 else [],
            "seconds": round(res.seconds, 2), "rss_mb": round(res.rss_mb), "env": res.case.env,
            "signature": signature(res)}
