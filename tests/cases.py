"""The cases of a command-line suite, for the sanitizer pass's sample (docs/testing.md "Cases and
the sanitizer sample").

A suite names each independent part of its work a case (`Cases.wanted(case)`): an input, a group
of checks, one capture's sweep. In release every case runs. In the sanitizer build ctest sets
DRIVETAP_SAMPLE to tests/sanitizer_sample.txt, which scripts/choose_sample.py chose by coverage:
a case it marks `skip` is left out (the cases it keeps reach every line and branch the suite
reaches); a case it does not list at all is new since the sample was chosen, and runs. A `run`
case the suite no longer has fails the suite, so a stale sample cannot silently shrink.

For the chooser, DRIVETAP_CASE_PROFILES=DIR makes every drivetap process of a case write its
coverage profile under DIR/<suite>/<case>/ (LLVM_PROFILE_FILE), and its wall time to
DIR/<suite>/<case>/seconds.
"""
import os
import re
import time

SAMPLE_LINE = re.compile(r"^(run|skip)\s+(\S+)\s+(\S+)\s*$")


def load_sample(path, suite):
    """{case: "run"|"skip"} of `suite` in the sample file at `path`."""
    marks = {}
    with open(path, encoding="utf-8") as f:
        for number, line in enumerate(f, 1):
            line = line.split("#", 1)[0].strip()
            if not line:
                continue
            m = SAMPLE_LINE.match(line)
            if not m:
                raise SystemExit(f"{path}:{number}: not 'run|skip SUITE CASE': {line!r}")
            if m.group(2) == suite:
                marks[m.group(3)] = m.group(1)
    return marks


def safe(case):
    return re.sub(r"[^A-Za-z0-9_.:+-]", "_", case)


class Cases:
    def __init__(self, suite):
        self.suite = suite
        sample = os.environ.get("DRIVETAP_SAMPLE")
        self.marks = load_sample(sample, suite) if sample else None
        self.profiles = os.environ.get("DRIVETAP_CASE_PROFILES")
        self.met = set()
        self.skipped = 0
        self.current = None
        self.started = 0.0
        self.outside = os.environ.get("LLVM_PROFILE_FILE")  # the work outside every case

    def wanted(self, case):
        """Whether `case` runs here. Call once per case, before its work."""
        case = safe(case)
        if case in self.met:
            raise SystemExit(f"{self.suite}: case {case} named twice")
        self.met.add(case)
        if self.marks is not None and self.marks.get(case) == "skip":
            self.skipped += 1
            return False
        return True

    def env(self, case):
        """The environment for a drivetap process of `case` (its coverage profile, if asked)."""
        env = dict(os.environ)
        if self.profiles:
            folder = os.path.join(self.profiles, self.suite, safe(case))
            os.makedirs(folder, exist_ok=True)
            env["LLVM_PROFILE_FILE"] = os.path.join(folder, "%p-%m.profraw")
        return env

    def begin(self, case):
        """wanted(case), and for a suite that runs one case at a time, the environment of its
        drivetap processes set in os.environ until the next begin() or finish()."""
        self._close()
        if not self.wanted(case):
            return False
        if self.profiles:
            os.environ["LLVM_PROFILE_FILE"] = self.env(case)["LLVM_PROFILE_FILE"]
        self.current, self.started = safe(case), time.monotonic()
        return True

    def timed(self, case, seconds):
        """Records the wall time of a case run outside begin() (a pool's worker)."""
        if self.profiles:
            folder = os.path.join(self.profiles, self.suite, safe(case))
            os.makedirs(folder, exist_ok=True)
            with open(os.path.join(folder, "seconds"), "a", encoding="utf-8") as f:
                f.write(f"{seconds:.3f}\n")

    def end(self):
        """Ends the current case: what follows is outside every case, and always runs."""
        self._close()

    def _close(self):
        if self.current is not None:
            self.timed(self.current, time.monotonic() - self.started)
            self.current = None
            if self.outside is None:
                os.environ.pop("LLVM_PROFILE_FILE", None)
            else:
                os.environ["LLVM_PROFILE_FILE"] = self.outside

    def finish(self):
        """A list of problems with the sample (empty when none), and a line saying what ran."""
        self._close()
        problems = []
        if self.marks is not None:
            for case, mark in sorted(self.marks.items()):
                if mark == "run" and case not in self.met:
                    problems.append(f"{self.suite}: the sanitizer sample runs case {case}, which "
                                    f"the suite no longer has: run scripts/choose_sample.py")
            new = len([c for c in self.met if c not in self.marks])
            print(f"{self.suite}: sample: {len(self.met) - self.skipped} of {len(self.met)} "
                  f"cases run ({new} new since the sample was chosen)")
        return problems
