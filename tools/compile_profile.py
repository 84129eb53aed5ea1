"""Where numba's compile time goes: the seconds each kernel took to compile, its callees' excluded.

    python tools/compile_profile.py default            # the README's kernels
    python tools/compile_profile.py methods --top 20

Runs warmup jobs (:data:`tinsmith.warmup.JOBS`) in a fresh numba cache
without the build's compiled kernels, listening to numba's compile events:
for each kernel and signature, the compile's own seconds (nested compiles of
the callees taken off), the seconds with them, and the count.  What decided
how the hot loops' helpers are inlined (``benchmarks/NOTES_jit.md``).
"""

from __future__ import annotations

import argparse
import collections
import os
import sys
import tempfile
import time


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("jobs", help="warmup jobs, comma-separated (tinsmith warmup --help lists them)")
    ap.add_argument("--top", type=int, default=30, help="kernels to list, the slowest first")
    args = ap.parse_args()
    os.environ["NUMBA_CACHE_DIR"] = tempfile.mkdtemp(prefix="tinsmith-compile-profile-")
    os.environ["TINSMITH_NO_PORTABLE_CACHE"] = "1"  # compile, rather than load what the build compiled

    from numba.core import event

    own, total, count = collections.Counter(), collections.Counter(), collections.Counter()
    stack = []

    class Listener(event.Listener):
        def on_start(self, e):
            stack.append([f"{e.data['dispatcher'].py_func.__qualname__} {e.data['args']}", time.perf_counter(), 0.0])

        def on_end(self, e):
            name, start, nested = stack.pop()
            seconds = time.perf_counter() - start
            own[name] += seconds - nested
            total[name] += seconds
            count[name] += 1
            if stack:
                stack[-1][2] += seconds

    event.register("numba:compile", Listener())
    from tinsmith.warmup import warmup

    start = time.perf_counter()
    warmup(args.jobs.split(","))
    print(f"jobs {args.jobs}: {time.perf_counter() - start:.1f} s, of which compiling {sum(own.values()):.1f} s")
    print(f"{'own s':>7} {'with callees':>12} {'n':>3}  kernel (signature)")
    for name, seconds in own.most_common(args.top):
        print(f"{seconds:7.1f} {total[name]:12.1f} {count[name]:3d}  {name[:160]}")


if __name__ == "__main__":
    sys.exit(main())
