#!/usr/bin/env python3
"""Chooses the sanitizer pass's sample of command-line cases by coverage (docs/testing.md "Cases
and the sanitizer sample"), and writes it to tests/sanitizer_sample.txt.

    python3 scripts/choose_sample.py [--build DIR] [--keep]

1. Builds drivetap with clang's source-based coverage in DIR (default build-cov).
2. Runs every command-line suite there (ctest -L sampled) with DRIVETAP_CASE_PROFILES set:
   each case's drivetap processes write their profiles to a folder of its own (tests/cases.py,
   tests/cases.sh), and the work outside any case to another.
3. Per case, the source lines and branch outcomes its processes reached (llvm-profdata merge,
   llvm-cov export -format=lcov).
4. Starting from what the work outside the cases reaches (it always runs), picks cases greedily
   by new lines and branches per second of their run, until the chosen cases reach all that
   every case reaches. Each suite's cases are chosen against the others', since one drivetap
   serves them all.

The sample lists every case it met, `run` or `skip`; a case added later is not listed and so
runs under the sanitizers until the sample is chosen again. Needs clang and llvm (Debian: clang,
llvm); takes about as long as a release ctest run plus a minute per hundred cases.
"""
import argparse
import concurrent.futures
import os
import shutil
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SAMPLE = os.path.join(ROOT, "tests", "sanitizer_sample.txt")
OUTSIDE = "_outside"


def tool(name):
    for candidate in (name, name + "-14", name + "-15", name + "-16"):
        if shutil.which(candidate):
            return candidate
    sys.exit(f"choose_sample.py: {name} not found (apt-get install llvm)")


def build(folder):
    subprocess.run(["cmake", "-S", ROOT, "-B", folder, "-G", "Ninja",
                    "-DCMAKE_BUILD_TYPE=RelWithDebInfo", "-DCMAKE_CXX_COMPILER=clang++",
                    "-DDRIVETAP_COVERAGE=ON", "-DDRIVETAP_BENCH=OFF"], check=True,
                   stdout=subprocess.DEVNULL)
    subprocess.run(["cmake", "--build", folder, "-j", str(os.cpu_count() or 2), "--target",
                    "drivetap", "drivetap-simbus"], check=True)


def run_suites(folder, profiles):
    env = dict(os.environ, DRIVETAP_CASE_PROFILES=profiles,
               LLVM_PROFILE_FILE=os.path.join(profiles, OUTSIDE, "%p-%m.profraw"),
               DRIVETAP_REQUIRE_TSHARK="1", DRIVETAP_REQUIRE_SIGROK="1",
               DRIVETAP_REQUIRE_CHROMIUM="1")
    env.pop("DRIVETAP_SAMPLE", None)
    done = subprocess.run(["ctest", "--test-dir", folder, "-L", "sampled", "--output-on-failure",
                           "-j", str(os.cpu_count() or 2)], env=env)
    if done.returncode != 0:
        sys.exit("choose_sample.py: a suite failed in the coverage build: fix it first")


def reached(folder, case_dir, binaries, scratch):
    """The lines ("L file:line") and branch outcomes ("B file:line:block:branch") of a case."""
    raws = [os.path.join(case_dir, f) for f in os.listdir(case_dir) if f.endswith(".profraw")]
    if not raws:
        return set()
    merged = os.path.join(scratch, os.path.basename(case_dir) + ".profdata")
    listing = os.path.join(scratch, os.path.basename(case_dir) + ".list")
    with open(listing, "w", encoding="utf-8") as f:
        f.write("\n".join(raws) + "\n")
    subprocess.run([tool("llvm-profdata"), "merge", "-sparse", "-f", listing, "-o", merged],
                   check=True)
    args = [tool("llvm-cov"), "export", "-format=lcov", "-instr-profile=" + merged, binaries[0]]
    for b in binaries[1:]:
        args += ["-object", b]
    out = subprocess.run(args, check=True, capture_output=True, text=True).stdout
    os.remove(merged)
    items, source = set(), ""
    for line in out.splitlines():
        if line.startswith("SF:"):
            source = os.path.relpath(line[3:], ROOT)
        elif line.startswith("DA:"):
            number, count = line[3:].split(",")[:2]
            if count != "0":
                items.add(f"L {source}:{number}")
        elif line.startswith("BRDA:"):
            number, block, branch, taken = line[5:].split(",")
            if taken not in ("0", "-"):
                items.add(f"B {source}:{number}:{block}:{branch}")
    # drivetap's own sources: not the headers of the system's libraries, not generated files.
    return {i for i in items if i.split()[1].startswith(("src/", "dissectors/", "tools/"))}


def seconds_of(case_dir):
    path = os.path.join(case_dir, "seconds")
    if not os.path.exists(path):
        return 1.0
    with open(path, encoding="utf-8") as f:
        return max(0.05, sum(float(x) for x in f.read().split()))


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--build", default=os.path.join(ROOT, "build-cov"))
    parser.add_argument("--keep", action="store_true", help="keep the profiles (in BUILD/profiles)")
    args = parser.parse_args()
    build(args.build)
    profiles = os.path.join(args.build, "profiles")
    shutil.rmtree(profiles, ignore_errors=True)
    os.makedirs(profiles)
    run_suites(args.build, profiles)
    binaries = [os.path.join(args.build, "drivetap"),
                os.path.join(args.build, "tools", "drivetap-simbus")]
    cases = []  # (suite, case, folder)
    for suite in sorted(os.listdir(profiles)):
        if suite == OUTSIDE:
            continue
        for case in sorted(os.listdir(os.path.join(profiles, suite))):
            cases.append((suite, case, os.path.join(profiles, suite, case)))
    with tempfile.TemporaryDirectory() as scratch:
        with concurrent.futures.ThreadPoolExecutor(os.cpu_count() or 2) as pool:
            outside = pool.submit(reached, args.build, os.path.join(profiles, OUTSIDE), binaries,
                                  scratch)
            items = list(pool.map(lambda c: reached(args.build, c[2], binaries, scratch), cases))
            covered = set(outside.result()) if os.path.isdir(os.path.join(profiles, OUTSIDE)) \
                else set()
    cost = [seconds_of(c[2]) for c in cases]
    everything = set(covered).union(*items) if items else set(covered)
    chosen = set()
    while True:
        best, best_gain = None, 0.0
        for i, reach in enumerate(items):
            if i in chosen:
                continue
            new = len(reach - covered)
            if new and new / cost[i] > best_gain:
                best, best_gain = i, new / cost[i]
        if best is None:
            break
        chosen.add(best)
        covered |= items[best]
    assert covered == everything
    total = sum(cost)
    kept = sum(cost[i] for i in chosen)
    lines = [i for i in everything if i.startswith("L ")]
    with open(SAMPLE, "w", encoding="utf-8") as f:
        f.write("# The sanitizer pass's sample of command-line cases (tests/cases.py), chosen by\n"
                "# scripts/choose_sample.py: the `run` cases reach every source line and branch\n"
                "# outcome that all the cases reach in a coverage build. Do not edit by hand:\n"
                "# run `python3 scripts/choose_sample.py` after adding or changing cases.\n")
        f.write(f"# {len(chosen)} of {len(cases)} cases; {len(lines)} lines and "
                f"{len(everything) - len(lines)} branch outcomes; {kept:.0f} s of "
                f"{total:.0f} s in the coverage build.\n")
        for i, (suite, case, _) in enumerate(cases):
            f.write(f"{'run ' if i in chosen else 'skip'} {suite} {case}\n")
    print(f"choose_sample.py: {len(chosen)} of {len(cases)} cases reach all {len(everything)} "
          f"lines and branch outcomes; {kept:.0f} s of {total:.0f} s; wrote "
          f"{os.path.relpath(SAMPLE, ROOT)}")
    if not args.keep:
        shutil.rmtree(profiles, ignore_errors=True)


if __name__ == "__main__":
    main()
