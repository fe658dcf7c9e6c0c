"""Autofocus on the family of simulated cases of ``tests/autofocus_family.py`` (no assertions;
prints a markdown table).

For each case (error kind × scene × flight path, and the user's case) and seed: the injected
error (rad rms, constant and linear part removed), and for PGA and minimum entropy what is left
of it with the residual the method's halves predicted (``-`` and the decision's code where
nothing was applied), with the time each took (wall, one process; timings on
shared cores are noisy). The targets: left ≤ injected everywhere; PGA ≤ 0.2 rad rms wherever
minimum entropy reaches it, or nothing applied.

Usage: ``python bench/bench_autofocus_family.py [--seeds 0,1,2] [--only WORD]``
"""

from __future__ import annotations

import argparse
import sys
import time
import warnings
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))   # the family lives in tests/

from tests.autofocus_family import GOOD_RAD, all_cases, family_case, user_case  # noqa: E402


def _run(case, method):
    from sarcli.autofocus import autofocus
    from sarcli.autofocus._common import AutofocusWarning

    t = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", AutofocusWarning)
        _, res = autofocus(case.bad, method)
    applied = bool(res.accepted and res.phase_rad.any())
    return case.residual(res.phase_rad), applied, time.perf_counter() - t, res


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", default="0,1,2")
    ap.add_argument("--only", default="", help="run only the cases whose name contains this")
    ap.add_argument("--methods", default="pga,min-entropy", help="the methods to run (others print -)")
    ap.add_argument("-v", action="store_true", help="print each decision")
    a = ap.parse_args()
    seeds = [int(s) for s in a.seeds.split(",")]
    methods = a.methods.split(",")
    builders = [(lambda s, c=c: family_case(*c, seed=s)) for c in all_cases()] + [user_case]
    print("| case | injected | PGA left (predicted) | PGA s | min-entropy left (predicted) | min-entropy s | target |")
    print("|---|---|---|---|---|---|---|")
    fails = worse = 0
    tally = {}
    for seed in seeds:
        t = tally.setdefault(seed, {"cases": 0, "pga": [0, 0], "min-entropy": [0, 0], "worse": 0, "missed": []})
        for build in builders:
            case = build(seed)
            if a.only and a.only not in case.name:
                continue
            inj = case.injected
            skip = (float("nan"), False, 0.0, None)
            (rp, ap_, tp, resp), (rm, am, tm, resm) = (_run(case, m) if m in methods else skip
                                                       for m in ("pga", "min-entropy"))
            bad = [m for m, r in (("PGA", rp), ("min-entropy", rm)) if r > inj + 1e-9]
            if rm <= GOOD_RAD and ap_ and rp > GOOD_RAD:
                bad.append("PGA > 0.2 where min-entropy reaches it")
            fails += bool(bad)
            worse += sum(r > inj + 1e-9 for r in (rp, rm))
            t["cases"] += 1
            t["worse"] += sum(r > inj + 1e-9 for r in (rp, rm))
            t["missed"] += [f"{case.name}: {b}" for b in bad]
            for m, r, on in (("pga", rp, ap_), ("min-entropy", rm, am)):
                t[m][0] += on
                t[m][1] += on and r <= GOOD_RAD

            def cell(r, on, res):
                if res is None:
                    return "not run"
                if not on:
                    return f"- ({res.code})"
                pred = res.history.get("trust", {}).get("predicted_rad")
                return f"{r:.3f}" + (f" ({pred:.3f})" if pred is not None else "")
            print(f"| {case.name} | {inj:.3f} | {cell(rp, ap_, resp)} | {tp:.1f} | {cell(rm, am, resm)} | {tm:.1f} | "
                  f"{'; '.join(bad) or 'met'} |", flush=True)
            if a.v:
                for r in (resp, resm):
                    if r is not None:
                        print(f"<!-- {r.describe()} -->")
    print("\n| seed | cases | PGA applied (within 0.2 rad) | min-entropy applied (within 0.2 rad) | left more than "
          "injected | targets missed |")
    print("|---|---|---|---|---|---|")
    for seed, t in tally.items():
        print(f"| {seed} | {t['cases']} | {t['pga'][0]} ({t['pga'][1]}) | {t['min-entropy'][0]} ({t['min-entropy'][1]}) "
              f"| {t['worse']} | {'; '.join(t['missed']) or 0} |")
    print(f"\n{fails} case(s) missing a target; {worse} result(s) left more than was injected")


if __name__ == "__main__":
    main()
