"""A fixed fast subset of the fuzz harness (tests/fuzz/; the full run: python tests/fuzz): about 36 malformed or
edge-case inputs covering every generator class (corrupt and crafted images, channel
layouts, pixel values, path kinds, depth files, YAML configs, --set values, --camera JSON,
command lines, batch folders). Each runs `fogcli` in a subprocess and must meet the
contract: exit 0 or a one-line exit 2 (3 for a batch with failed frames), no traceback or
warning, no hang, nothing left behind, inputs unchanged, outputs readable."""

import pytest


from fuzz.cases import CLASSES, build_cases, fast_cases
from fuzz.report import command_line, run_case

CASES = fast_cases()


@pytest.mark.parametrize("case", CASES, ids=[f"{c.id}:{c.variant[:40]}" for c in CASES])
def test_fuzz_case_meets_the_contract(case, tmp_path):
    res = run_case(case, tmp_path)
    assert not res.kinds, (
        f"{command_line(case)}\nexit {res.rc}, {res.seconds:.1f} s, {res.rss_mb:.0f} MB: "
        f"{', '.join(res.kinds)}\nstderr:\n" + "\n".join(res.stderr.splitlines()[:8]))


def test_generators_are_deterministic_and_broad():
    a = [(c.id, c.variant, c.args) for c in build_cases(240, seed=3)]
    b = [(c.id, c.variant, c.args) for c in build_cases(240, seed=3)]
    assert a == b
    assert {c.cls for c in CASES} == set(CLASSES)
    assert len(build_cases(1000)) == 1000
