"""Fuzz the command line with malformed inputs and check fogcli's contract on every case.

    python tests/fuzz [--cases N] [--seed S] [--out DIR] [--work DIR] [--classes a,b]

Each case is a tiny folder of inputs (written by a seeded, deterministic generator) and one
`fogcli` command run in it as a subprocess (30 s timeout, its own process group). The
contract checked per case:

* exit 0, or 2 with exactly one stderr line starting with "fogcli: " or a file name (check:
  every line names its file); 3 only for `batch` (every stderr line "fogcli: ...", progress
  lines "[i/N] ..." tolerated); 1 is a defect for bad input (a device failure is not
  expected from these tiny inputs); anything else (signals) is a crash;
* no "Traceback", no Python / library warning lines (the word "warning" only in
  "fogcli: warning: ..."), no stray stderr lines on success;
* no hang (timeout), peak RSS (wait4's ru_maxrss of the child) at most 4 GB;
* nothing left behind: the folder holds the inputs plus, after exit 0, the expected outputs
  (batch: the output / save-depth folders and the report, also after exit 3); never a
  temporary file (".*.tmp*");
* inputs byte-identical afterwards;
* outputs of a success read back (OpenImageIO / NPY / JSON) and their colour is finite;
* obviously invalid inputs (missing, empty, truncated, ...) are refused, obviously valid
  ones are not.

Prints a table of counts per generator class and writes every defect (case id, class,
command, exit code, first stderr lines) to OUT/defects.json, with a grouping by signature
in OUT/signatures.json. tests/test_fuzz.py runs a fixed fast subset (cases.fast_cases()).

As root, the commands run without CAP_DAC_OVERRIDE (setpriv), so that read-only folders and
unreadable files behave as they do for a user.
"""
