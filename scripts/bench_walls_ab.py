#!/usr/bin/python3
"""Wall time of `reconstruct` under two binaries, measured in turn on the same
captures in the same hour: the speed of a change without the machine's drift.

The benchmarks' walls move 5-28 % between hours on this shared 2-core machine,
so a speed change is measured here by running binary A and binary B one after
the other on each capture (A, B, A, B, ... never side by side), with the same
options, and comparing their walls, their split-search trials and their
choices (the log's model lines and chosen count must match for a pure speed
change).

Usage:
  /usr/bin/python3 scripts/bench_walls_ab.py --a OLD_BINARY --b NEW_BINARY \\
      --captures CAP1 CAP2 ... [--labels BEFORE AFTER] [--threads 2] \\
      [--work /tmp/walls_ab] [--out bench_results/walls_ab]
  /usr/bin/python3 scripts/bench_walls_ab.py --report-only [--out ...]   # rewrite OUT.md from OUT.json
Each CAP is a capture folder with scene.json. Writes OUT.json and OUT.md.
"""
import argparse
import datetime
import json
import os
import re
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import bench  # noqa: E402  (run, snapshot_binary, environment, write_atomic)


def run(binary, capture, out, threads):
    """One reconstruct; returns wall seconds, split trials and the choices."""
    log = out + ".log"
    if os.path.exists(log):
        os.remove(log)  # bench.run appends
    try:
        wall, _, _ = bench.run([binary, "reconstruct", os.path.join(capture, "scene.json"), "--out", out,
                                "--threads", str(threads), "--no-report"], log)
    except bench.StepError as e:
        sys.exit("bench_walls_ab: %s on %s: %s (log %s)" % (binary, capture, e, log))
    text = open(log).read()
    trials = len(re.findall(r"\] \d+ clusters \(split of", text))
    # The decisions, without timestamps: chosen count and every model choice.
    choices = [re.sub(r"^\s*\[[^]]*\]\s*", "", l) for l in text.splitlines()
               if re.search(r"\] (chosen:|cluster \d+: model )", l)]
    return {"wall_s": wall, "trials": trials, "choices": choices}


def write_markdown(doc, path):
    bins = doc["binaries"]
    lines = ["# Walls of `reconstruct`, two binaries in turn", "",
             "Measured %s by `scripts/bench_walls_ab.py`: on each capture binary A, then binary B, one after the "
             "other (never side by side), `reconstruct --threads %d --no-report`; wall from process start to exit. "
             "Same choices: the log's chosen count and every model choice are the same for both." % (
                 doc["date"], doc["threads"]),
             "", "A: %s (sha256 `%s`); B: %s (sha256 `%s`)." % (
                 bins["A"].get("label", bins["A"]["path"]), bins["A"]["sha256"], bins["B"].get("label", bins["B"]["path"]),
                 bins["B"]["sha256"]), "",
             "| capture | A wall s | B wall s | B - A | split trials A / B | same choices |", "|---|---:|---:|---:|---|---|"]
    for r in doc["rows"]:
        lines.append("| %s | %.2f | %.2f | %+.2f | %d / %d | %s |" % (
            r["name"], r["A"]["wall_s"], r["B"]["wall_s"], r["B"]["wall_s"] - r["A"]["wall_s"], r["A"]["trials"],
            r["B"]["trials"], "yes" if r["same_choices"] else "**no**"))
    bench.write_atomic(path, "\n".join(lines) + "\n")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--a", help="binary A (before)")
    ap.add_argument("--b", help="binary B (after)")
    ap.add_argument("--labels", nargs=2, metavar=("A", "B"), help="names of the binaries in the report (e.g. commits)")
    ap.add_argument("--captures", nargs="+", help="capture folders (scene.json inside)")
    ap.add_argument("--report-only", action="store_true", help="rewrite OUT.md from OUT.json, run nothing")
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--work", default="/tmp/walls_ab")
    ap.add_argument("--out", default=os.path.join(os.path.dirname(HERE), "bench_results", "walls_ab"))
    a = ap.parse_args(argv)
    if a.report_only:
        write_markdown(json.load(open(a.out + ".json")), a.out + ".md")
        return
    if not (a.a and a.b and a.captures):
        ap.error("--a, --b and --captures are required (or --report-only)")
    for c in a.captures:
        if not os.path.isfile(os.path.join(c, "scene.json")):
            sys.exit("bench_walls_ab: %s has no scene.json" % c)
    os.makedirs(a.work, exist_ok=True)
    bins = {}
    labels = a.labels or [os.path.basename(a.a), os.path.basename(a.b)]
    for tag, path, label in (("A", a.a, labels[0]), ("B", a.b, labels[1])):
        snap, sha = bench.snapshot_binary(path, os.path.join(a.work, tag))
        bins[tag] = {"path": path, "label": label, "snapshot": snap, "sha256": sha}
    rows = []
    for c in a.captures:
        name = os.path.basename(os.path.normpath(c))
        row = {"capture": c, "name": name}
        for tag in ("A", "B"):
            row[tag] = run(bins[tag]["snapshot"], c, os.path.join(a.work, "%s-%s" % (name, tag)), a.threads)
            print("%-10s %s %6.2f s  %d trials" % (name, tag, row[tag]["wall_s"], row[tag]["trials"]), flush=True)
        row["same_choices"] = row["A"]["choices"] == row["B"]["choices"]
        rows.append(row)
    doc = {"date": datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ"),
           "threads": a.threads, "binaries": bins, "env": bench.environment(bins["B"]["snapshot"], bins["B"]["sha256"]),
           "rows": rows}
    bench.write_atomic(a.out + ".json", json.dumps(doc, indent=1) + "\n")
    write_markdown(doc, a.out + ".md")
    print("wrote %s.{md,json}" % a.out)


if __name__ == "__main__":
    main()
