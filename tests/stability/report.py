"""Write ``docs/stability.md`` from the stability cases (the tests assert the same rows).

Usage (from the repository root)::

    python -m tests.stability.report [-o docs/stability.md] [--only KEY ...] [--no-faults]
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
import warnings
from pathlib import Path

from . import extreme, faults

ROOT = Path(__file__).resolve().parents[2]


def build(only=None, with_faults=True) -> str:
    """The whole document: numerical extremes, broken files, hostile input and faults."""
    t0 = time.perf_counter()
    results = []
    for case in extreme.CASES:
        if only and case.key not in only:
            continue
        outcomes = case.run()
        results.append((case, outcomes))
        print(f"{case.key} {case.config}: {len(outcomes)} outcomes, {sum(not o.passed for o in outcomes)} failing",
              file=sys.stderr)
    with tempfile.TemporaryDirectory() as tmp:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            bad_rows = extreme.run_bad_inputs(Path(tmp))
    lines = extreme.render(results, bad_rows, time.perf_counter() - t0)
    if with_faults:
        with tempfile.TemporaryDirectory() as tmp:
            rows = faults.run_all(tmp)
        print(f"faults: {len(rows)} cases, {sum(not r.passed for r in rows)} failing", file=sys.stderr)
        lines += [""] + faults.render(rows)
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("-o", "--output", default=str(ROOT / "docs" / "stability.md"))
    ap.add_argument("--only", nargs="*", default=None, help="numerical case keys to run (default: all)")
    ap.add_argument("--no-faults", action="store_true", help="skip the hostile-input and fault cases")
    args = ap.parse_args(argv)
    text = build(args.only, with_faults=not args.no_faults)
    from sarcli._util.atomic import atomic_path

    with atomic_path(args.output) as tmp:
        Path(tmp).write_text(text)
    print(f"wrote {args.output}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
