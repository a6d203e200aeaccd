"""python tests/fuzz [--cases N] [--seed S] [--out DIR] [--work DIR] [--classes a,b]: the full
run of the fuzz harness (tests/test_fuzz.py runs its fast subset)."""
from __future__ import annotations

import argparse
import json
import shutil
import sys
import tempfile
import time
from pathlib import Path

# run as a folder: the harness is the package `fuzz` beside the tests' helpers
sys.path[:0] = [str(Path(__file__).resolve().parents[1])]

from fuzz.cases import CLASSES, build_cases, fast_cases
from fuzz.files import TIMEOUT
from fuzz.judge import _restore_perms
from fuzz.report import defect_record, print_table, run_case, summarise


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--cases", type=int, default=1200)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out", default="/tmp/fuzz-out", help="folder for defects.json and signatures.json")
    ap.add_argument("--work", default=None, help="scratch folder for the case folders (default: a temporary one)")
    ap.add_argument("--classes", default="", help="comma-separated subset of: " + ", ".join(CLASSES))
    ap.add_argument("--fast", action="store_true", help="only the fixed fast subset of tests/test_fuzz.py")
    ap.add_argument("--timeout", type=float, default=TIMEOUT)
    ap.add_argument("--keep", action="store_true", help="keep every case folder (default: only defective ones)")
    ap.add_argument("--dry-run", action="store_true", help="only write every case's inputs (checks the generators)")
    a = ap.parse_args(argv)
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    work = Path(a.work) if a.work else Path(tempfile.mkdtemp(prefix="fogcli-fuzz-"))
    work.mkdir(parents=True, exist_ok=True)
    classes = [c for c in a.classes.split(",") if c]
    cases = fast_cases(a.seed) if a.fast else build_cases(a.cases, a.seed, classes)
    print(f"fuzz: {len(cases)} cases, seed {a.seed}, work {work}, out {out}", file=sys.stderr)
    if a.dry_run:
        for case in cases:
            folder = work / case.id
            folder.mkdir(parents=True, exist_ok=True)
            if case.setup:
                case.setup(folder)
            _restore_perms(folder)
            shutil.rmtree(folder)
        print(f"dry run: {len(cases)} cases set up", file=sys.stderr)
        return 0
    results = []
    t0 = time.perf_counter()
    for k, case in enumerate(cases, 1):
        res = run_case(case, work, a.timeout, a.keep)
        results.append(res)
        if res.kinds:
            first = next((ln for ln in res.stderr.splitlines() if ln.strip()), "")
            print(f"[{k}/{len(cases)}] {case.id} {case.variant[:50]!r} exit {res.rc}: "
                  f"{', '.join(res.kinds)[:120]} | {first[:140]}", file=sys.stderr, flush=True)
        elif k % 50 == 0:
            print(f"[{k}/{len(cases)}] {time.perf_counter() - t0:.0f} s", file=sys.stderr, flush=True)
    table = summarise(results)
    print_table(table)
    defects = [defect_record(r) for r in results if r.kinds]
    groups: dict[str, dict] = {}
    for d in defects:
        g = groups.setdefault(d["signature"], {"count": 0, "example": d, "ids": []})
        g["count"] += 1
        g["ids"].append(d["id"])
    (out / "defects.json").write_text(json.dumps(defects, indent=1, ensure_ascii=False))
    (out / "signatures.json").write_text(json.dumps(groups, indent=1, ensure_ascii=False))
    (out / "results.json").write_text(json.dumps(
        [{"id": r.case.id, "variant": r.case.variant, "exit": r.rc, "seconds": round(r.seconds, 2),
          "rss_mb": round(r.rss_mb), "kinds": r.kinds} for r in results], indent=0, ensure_ascii=False))
    top = sorted(results, key=lambda r: -r.rss_mb)[:3]
    print("largest peak RSS: " + "; ".join(f"{r.case.id} {r.case.variant[:30]} {r.rss_mb:.0f} MB" for r in top))
    (out / "summary.json").write_text(json.dumps({"seed": a.seed, "cases": len(results),
                                                  "seconds": round(time.perf_counter() - t0, 1),
                                                  "table": table}, indent=1))
    print(f"{len(defects)} defective cases, {len(groups)} signatures; {out / 'defects.json'} "
          f"({time.perf_counter() - t0:.0f} s)")
    if not a.work and not a.keep:
        _restore_perms(work)
        shutil.rmtree(work / "_io", ignore_errors=True)
        if not defects:
            shutil.rmtree(work, ignore_errors=True)
    return 1 if defects else 0


if __name__ == "__main__":
    sys.exit(main())
