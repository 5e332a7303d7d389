"""Nightly fuzz campaign of the ``splice`` command (issue 10): the seeded mutational fuzz of
tests/test_fuzz.py, run for longer, with a table of cases and classes.

    python benchmarks/fuzz_nightly.py --minutes 5            # seeds 1000, 1001, ... until time is up
    python benchmarks/fuzz_nightly.py --cases 20000 --seed 7 --no-shared

Exit status 1 when any case falls outside the accepted classes (success with a valid output,
or exit 1/2 with one short line and nothing written); each such case is listed with its
mutations so that it can be replayed (``--replay SEED:INDEX``).
"""

from __future__ import annotations

import argparse
import collections
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT), str(ROOT / "tests")]

import fuzzkit  # noqa: E402

BATCH = 500


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--minutes", type=float, default=None, help="run batches of 500 cases until this much time has passed")
    p.add_argument("--cases", type=int, default=None, help="run this many cases (default 5,000 without --minutes)")
    p.add_argument("--seed", type=int, default=1000, help="first batch seed (batch k uses seed + k)")
    p.add_argument("--no-shared", action="store_true", help="only the bundled sample files")
    p.add_argument("--replay", metavar="SEED:INDEX", help="run one case and print its class and mutations")
    args = p.parse_args(argv)
    pairs = fuzzkit.base_pairs(shared=not args.no_shared)
    if args.replay:
        seed, index = (int(x) for x in args.replay.split(":"))
        case = fuzzkit.make_cases(seed, index + 1, pairs)[index]
        print(case.mutations, case.argv)
        print(fuzzkit.run_cases([case])[0])
        return 0
    budget = args.cases if args.cases is not None else (None if args.minutes else 5000)
    deadline = time.monotonic() + 60 * args.minutes if args.minutes else None
    t0 = time.monotonic()
    counts: collections.Counter = collections.Counter()
    by_base: dict = collections.defaultdict(collections.Counter)
    bad = []
    seed = args.seed
    done = 0
    while (budget is None or done < budget) and (deadline is None or time.monotonic() < deadline):
        n = BATCH if budget is None else min(BATCH, budget - done)
        cases = fuzzkit.make_cases(seed, n, pairs)
        results = fuzzkit.run_cases(cases)
        for k, (case, (cls, detail)) in enumerate(zip(cases, results)):
            counts[cls] += 1
            by_base[case.mutations[0]][cls] += 1
        bad += [(seed, k, c, d, m) for k, (case, (c, d)) in enumerate(zip(cases, results))
                for m in [case.mutations] if (c, d, m) in fuzzkit.failures([case], [(c, d)])]
        done += n
        seed += 1
        print(f"{done:7d} cases, {time.monotonic() - t0:6.0f} s: {dict(counts)}", file=sys.stderr, flush=True)
    elapsed = time.monotonic() - t0
    classes = ["ok", "refused", "known-geometry", "traceback", "hang", "memory", "bad-message", "left-output",
               "bad-output", "crash"]
    print(f"Fuzz campaign: {done:,} cases in {elapsed:.0f} s ({done / elapsed:.1f} cases/s), seeds "
          f"{args.seed}..{seed - 1}, {len(pairs)} base pairs\n")
    print("| base pair | cases | " + " | ".join(classes) + " |")
    print("|---|---:|" + "---:|" * len(classes))
    for base in sorted(by_base):
        c = by_base[base]
        print(f"| {base} | {sum(c.values()):,} | " + " | ".join(f"{c[k]:,}" for k in classes) + " |")
    print(f"| **all** | **{done:,}** | " + " | ".join(f"**{counts[k]:,}**" for k in classes) + " |")
    if bad:
        print(f"\n{len(bad)} case(s) outside the accepted classes:")
        for seed_, k, c, d, m in bad[:50]:
            print(f"  --replay {seed_}:{k}  {c}: {d}  {m}")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
