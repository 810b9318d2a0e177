"""Coverage of the stated uncertainties, every method (issue 11): the table of docs/coverage.md.

Run from the repository root::

    python benchmarks/coverage.py                     # every case, 400 experiments each
    python benchmarks/coverage.py -n 2000             # more experiments
    python benchmarks/coverage.py -k vre -k tumble    # cases whose name contains a word
    python benchmarks/coverage.py --markdown table.md
    python benchmarks/coverage.py --update-docs       # the table of docs/coverage.md
    python benchmarks/coverage.py -k head --update-docs   # only those cases' rows of it

For each case (every ReductionContract subclass of tests/methods/*/test_*_contract.py
and the extra cases of tests/helpers/coverage.py) it runs N simulated
experiments (seeds 0..N-1) and prints, per coefficient, the ratio of the
empirical SD of (estimate - truth) to the mean stated SD (target 0.9-1.1)
and the coverage of the stated 95 % interval (target 0.93-0.97; k from
Student's t of the reduction's dof). The verdict compares with the exact
targets; tests/uncertainty/test_coverage.py asserts the same numbers against bands
widened by their sampling error.
"""

import argparse
import os
import sys
from pathlib import Path

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")  # before numpy loads its BLAS

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs" / "coverage.md"
MARKER = "<!-- coverage-table -->"
sys.path.insert(0, str(ROOT / "tests"))  # the test helpers (tests/helpers), not installed

from helpers import coverage as harness  # noqa: E402


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("-n", "--experiments", type=int, default=None,
                        help=f"experiments per case (default {harness.DEFAULT_EXPERIMENTS}, "
                             "or more where a case asks for more)")
    parser.add_argument("-k", "--keyword", action="append", default=[],
                        help="run only cases whose name contains this (repeatable)")
    parser.add_argument("--markdown", type=Path, help="also write the markdown table here")
    parser.add_argument("--update-docs", action="store_true",
                        help=f"replace the table in {DOCS.relative_to(ROOT)} (after {MARKER})")
    parser.add_argument("--intervals", action="append", default=[], metavar="KIND",
                        help="instead: coverage of the 68.3 %% intervals of a deviation kind "
                             "per tau, for every power-law noise (1000 series of 4096 samples; "
                             "repeatable; the table of docs/noise.md)")
    args = parser.parse_args(argv)
    if args.intervals:
        return intervals(args.intervals, args.experiments or 1000)

    results = []
    header = (f"{'method':<58} {'coefficient':<12} {'SD ratio':>14} {'coverage':>8} "
              f"{'mean z':>7} {'N':>5} {'seconds':>7}  verdict")
    print(header)
    print("-" * len(header))
    for name, factory in harness.cases().items():
        if args.keyword and not any(k in name for k in args.keyword):
            continue
        res = harness.coverage(factory(), args.experiments, name=name)
        results.append(res)
        for c in res.coefficients.values():
            print(f"{name:<58} {c.coefficient:<12} {c.sd_ratio:6.3f} ± {c.sd_ratio_se:5.3f} "
                  f"{c.coverage:8.3f} "
                  f"{c.mean_z:+7.3f} {c.experiments:5d} {res.seconds:7.1f}  "
                  f"{harness.verdict_of(c)}", flush=True)
        for seed, exc in res.failures:
            print(f"{name:<58} FAILED seed {seed}: {exc}", flush=True)
    table = harness.markdown_table(results)
    if args.markdown:
        args.markdown.write_text(table)
        print(f"\nwrote {args.markdown}")
    if args.update_docs:
        text = DOCS.read_text(encoding="utf-8")
        head = text[:text.index(MARKER) + len(MARKER)]
        if args.keyword:  # the cases run replace their rows; the others' rows stay
            table = merged(text[len(head):], table, [r.case for r in results])
        DOCS.write_text(f"{head}\n\n{table}", encoding="utf-8")
        print(f"\nupdated {DOCS}")
    return 0


def merged(old: str, new: str, cases: list[str]) -> str:
    """The docs' table with the rows of ``cases`` from ``new``, in the harness's case order."""
    def rows(table: str) -> list[str]:
        return [line for line in table.splitlines() if line.startswith("| ")][1:]

    order = list(harness.cases())
    kept = [r for r in rows(old) if r.split(" | ")[0][2:] not in cases]
    both = sorted(kept + rows(new), key=lambda r: order.index(r.split(" | ")[0][2:])
                  if r.split(" | ")[0][2:] in order else len(order))
    head = new.splitlines()[:2]
    return "\n".join([*head, *both]) + "\n"


def intervals(kinds: list[str], trials: int) -> int:
    """Print, per kind and noise, the coverage of the 68.3 % intervals at each octave tau."""
    for kind in kinds:
        for alpha, noise in harness.INTERVAL_NOISES.items():
            m, cover, right = harness.interval_coverage(kind, alpha, trials)
            print(f"{kind} {noise} (alpha {alpha}), {trials} series")
            print("  m        " + " ".join(f"{int(v):>5d}" for v in m))
            print("  coverage " + " ".join(f"{v:5.3f}" for v in cover))
            print("  alpha ok " + " ".join(f"{v:5.2f}" for v in right), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
