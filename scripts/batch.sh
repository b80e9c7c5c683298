#!/usr/bin/env bash
# Reconstructs a folder of captures: one capture per task of a Slurm job array
# (sbatch --array), or, without Slurm (or with --local), the same task script
# run for each capture in turn on this machine. Every task writes
#   OUT/<capture>/material/      the material folder (svbrdf reconstruct)
#   OUT/<capture>/time.txt       /usr/bin/time -v of the reconstruction
#   OUT/<capture>/exit_code      the reconstruction's exit code
#   OUT/<capture>/evaluate.txt   held-out PSNR when the capture has heldout/scene.json
#                                (relit with `svbrdf relight RELIGHT_OPTIONS`, see --relight)
# and a final step collects OUT/summary.md and OUT/summary.json (a table: clusters,
# held-out PSNR, wall and CPU seconds, peak memory per capture).
#
# Usage: scripts/batch.sh CAPTURES_DIR OUT_DIR [--local] [--slurm] [--wait] [--partition P]
#                         [--time-limit MIN] [--max-parallel N] [--cpus N] [--mem SIZE]
#                         [--poll SEC] [--relight "OPTIONS"] [-- reconstruct options...]
#   CAPTURES_DIR: every sub-folder holding a scene.json is one capture.
#   --relight: relight options of the held-out scoring (default "--spp 8
#     --adaptive-rounds 16": a camera pixel integrates its footprint, as real
#     cameras and Mitsuba's box filter do, and pixels over edges or a scan's
#     turning normals take rounds of 8x8 samples until converged; "--spp 1" for photos rendered at the pixel centre; add
#     "--bounces 2" for captures with interreflection).
#   Default: Slurm when `sbatch` is on PATH and a Slurm controller answers
#     (`sinfo`), else local (slurm-wlm installed but not configured: local).
#   Slurm: CAPTURES_DIR, OUT_DIR and the svbrdf binary ($SVBRDF, default
#     build/apps/svbrdf) must be at the same paths on the compute nodes (a shared
#     file system). Each task asks for --cpus (default 2; reconstruct gets
#     --threads N unless given after --) and --mem (default 1G); tasks run in
#     OUT_DIR. Without --wait the script returns once the array and its summary
#     job are queued; with --wait it polls squeue every --poll seconds (default
#     10) until both left the queue, prints OUT/summary.md and exits 1 when a
#     capture failed (as the local mode does). Tested on a single-node Slurm by
#     scripts/test_slurm.sh (docs/guide/slurm.md).
# Example: scripts/batch.sh captures/ results/ -- --time-budget 30
set -euo pipefail
ROOT="$(cd "$(dirname "$0")/.." && pwd)"
SVBRDF="${SVBRDF:-$ROOT/build/apps/svbrdf}"

usage() { awk 'NR > 1 && !/^#/ { exit } NR > 1 { sub(/^# ?/, ""); print }' "$0"; exit "${1:-0}"; }

# --- one task: reconstruct (and evaluate) capture number $1 of the list ----
run_task() {
  local out="$1" index="$2"
  shift 2
  local scene name dir
  scene="$(sed -n "$((index + 1))p" "$out/captures.txt")"
  [ -n "$scene" ] || { echo "batch: no capture number $index in $out/captures.txt" >&2; exit 2; }
  name="$(basename "$(dirname "$scene")")"
  dir="$out/$name"
  mkdir -p "$dir"
  echo "[task $index] $name: reconstruct $scene" >&2
  local rc=0
  /usr/bin/time -v -o "$dir/time.txt" "$SVBRDF" reconstruct "$scene" --out "$dir/material" "$@" \
    > "$dir/reconstruct.log" 2>&1 || rc=$?
  echo "$rc" > "$dir/exit_code"
  local heldout
  heldout="$(dirname "$scene")/heldout/scene.json"
  if [ "$rc" -eq 0 ] && [ -f "$heldout" ]; then
    # shellcheck disable=SC2086  # RELIGHT_OPTIONS holds several words
    "$SVBRDF" relight "$dir/material" "$heldout" --out "$dir/relit" ${RELIGHT_OPTIONS:---spp 8 --adaptive-rounds 16} > "$dir/relight.log" 2>&1 &&
      "$SVBRDF" evaluate "$dir/relit" "$heldout" > "$dir/evaluate.txt" 2>&1 || true
    rm -rf "$dir/relit"
  fi
  echo "[task $index] $name: exit $rc" >&2
  return "$rc"
}

# --- summary table of every task's results --------------------------------
summarize() {
  /usr/bin/python3 - "$1" <<'EOF'
import json, os, re, sys
out = sys.argv[1]
rows = []
for line in open(os.path.join(out, "captures.txt")):
    scene = line.strip()
    if not scene:
        continue
    name = os.path.basename(os.path.dirname(scene))
    d = os.path.join(out, name)
    row = {"capture": name, "scene": scene, "exit_code": None,
           "relight_options": os.environ.get("RELIGHT_OPTIONS", "")}
    try:
        row["exit_code"] = int(open(os.path.join(d, "exit_code")).read())
    except (OSError, ValueError):
        pass
    try:
        t = open(os.path.join(d, "time.txt")).read()
        g = lambda k: re.search(re.escape(k) + r":\s*(\S+)", t).group(1)
        wall = g("Elapsed (wall clock) time (h:mm:ss or m:ss)").split(":")
        row["wall_s"] = sum(float(x) * 60 ** i for i, x in enumerate(reversed(wall)))
        row["cpu_s"] = float(g("User time (seconds)")) + float(g("System time (seconds)"))
        row["peak_mb"] = int(g("Maximum resident set size (kbytes)")) / 1024.0
    except (OSError, AttributeError):
        pass
    try:
        s = json.load(open(os.path.join(d, "material", "report", "summary.json")))
        row["clusters"] = s.get("clusters")
        row["texels"] = s.get("texels")
        row["samples"] = s.get("samples", {}).get("kept")
        row["time_budget_s"] = s.get("time_budget_s")
    except (OSError, ValueError):
        pass
    try:
        m = re.search(r"mean PSNR ([\d.]+) dB \(min ([\d.]+)\)", open(os.path.join(d, "evaluate.txt")).read())
        row["heldout_psnr_db"], row["heldout_psnr_min_db"] = float(m.group(1)), float(m.group(2))
    except (OSError, AttributeError):
        pass
    rows.append(row)
json.dump(rows, open(os.path.join(out, "summary.json"), "w"), indent=2)
fmt = lambda v, f: "" if v is None else f % v
L = ["# Batch reconstruction summary", "",
     "Held-out PSNR of `svbrdf relight %s`." % os.environ.get("RELIGHT_OPTIONS", ""), "",
     "| capture | exit | clusters | held-out PSNR (dB) | wall (s) | CPU (s) | peak (MB) |",
     "|---|---:|---:|---:|---:|---:|---:|"]
for r in rows:
    L.append("| %s | %s | %s | %s | %s | %s | %s |" % (
        r["capture"], fmt(r.get("exit_code"), "%d"), fmt(r.get("clusters"), "%d"),
        fmt(r.get("heldout_psnr_db"), "%.2f"), fmt(r.get("wall_s"), "%.1f"), fmt(r.get("cpu_s"), "%.1f"),
        fmt(r.get("peak_mb"), "%.0f")))
done = [r for r in rows if r.get("exit_code") == 0]
if done:
    mean = lambda k: sum(r.get(k, 0) or 0 for r in done) / len(done)
    L += ["", "%d of %d captures done; per capture: mean wall %.1f s, mean CPU %.1f s, mean peak %.0f MB." % (
        len(done), len(rows), mean("wall_s"), mean("cpu_s"), mean("peak_mb"))]
open(os.path.join(out, "summary.md"), "w").write("\n".join(L) + "\n")
print("\n".join(L))
EOF
}

# Internal entry points (used by the Slurm job scripts).
if [ "${1:-}" = "--task" ]; then
  shift
  out="$1"; shift
  run_task "$out" "${SLURM_ARRAY_TASK_ID:?--task needs SLURM_ARRAY_TASK_ID}" "$@"
  exit $?
fi
if [ "${1:-}" = "--summarize" ]; then summarize "$2"; exit 0; fi

[ $# -ge 2 ] || usage 2
case "$1" in -h|--help) usage 0;; esac
captures="$(cd "$1" && pwd)"
mkdir -p "$2"
out="$(cd "$2" && pwd)"
shift 2
mode=auto partition="" time_limit=30 max_parallel="" wait=0 cpus=2 mem=1G poll=10
export RELIGHT_OPTIONS="${RELIGHT_OPTIONS:---spp 8 --adaptive-rounds 16}"
while [ $# -gt 0 ]; do
  case "$1" in
    --local) mode=local; shift;;
    --slurm) mode=slurm; shift;;
    --partition) partition="$2"; shift 2;;
    --time-limit) time_limit="$2"; shift 2;;
    --max-parallel) max_parallel="$2"; shift 2;;
    --wait) wait=1; shift;;
    --cpus) cpus="$2"; shift 2;;
    --mem) mem="$2"; shift 2;;
    --poll) poll="$2"; shift 2;;
    --relight) RELIGHT_OPTIONS="$2"; shift 2;;
    --) shift; break;;
    -h|--help) usage 0;;
    *) echo "batch: unknown option $1 (reconstruct options go after --)" >&2; exit 2;;
  esac
done
[ -x "$SVBRDF" ] || { echo "batch: $SVBRDF not built (bash scripts/setup.sh)" >&2; exit 2; }

find "$captures" -mindepth 2 -maxdepth 2 -name scene.json | sort > "$out/captures.txt"
n=$(wc -l < "$out/captures.txt")
[ "$n" -gt 0 ] || { echo "batch: no */scene.json under $captures" >&2; exit 2; }
rm -f "$out/summary.md" "$out/summary.json"  # a previous run's would pass for this one's
if [ "$mode" = auto ]; then
  mode=local
  if command -v sbatch > /dev/null; then
    if timeout 30 sinfo --noheader --format %P > /dev/null 2>&1; then
      mode=slurm
    else
      echo "batch: sbatch is installed but no Slurm controller answers (sinfo); running locally" >&2
    fi
  fi
fi
echo "batch: $n captures, $mode, results in $out" >&2

if [ "$mode" = slurm ]; then
  for c in sbatch squeue; do
    command -v "$c" > /dev/null || { echo "batch: --slurm needs $c on PATH" >&2; exit 2; }
  done
  mkdir -p "$out/logs"
  array="0-$((n - 1))${max_parallel:+%$max_parallel}"
  extra=()
  [ -n "$partition" ] && extra+=(--partition "$partition")
  # reconstruct uses the task's cores unless the options say otherwise
  # (a second --threads would be an error).
  threads=(--threads "$cpus")
  for a in "$@"; do case "$a" in --threads|--threads=*) threads=();; esac; done
  # sbatch runs a copy of this script from slurmd's spool folder, so the job
  # finds nothing relative to it: it gets the binary and the relight options
  # through the environment and works in OUT_DIR (which exists on the nodes,
  # unlike, perhaps, the folder this was started from). One capture per array
  # task: 2 cores, 1 GB by default (a 75 k-triangle scan peaks below 500 MB),
  # wall limit in minutes.
  submitted=$(sbatch --parsable --job-name svbrdf-batch --array "$array" --cpus-per-task "$cpus" --mem "$mem" \
    --time "$time_limit" --chdir "$out" --output "$out/logs/%A_%a.out" "${extra[@]}" \
    --export "ALL,SVBRDF=$SVBRDF" "$0" --task "$out" "${threads[@]}" "$@")
  jobid=${submitted%%;*}
  [[ "$jobid" =~ ^[0-9]+$ ]] || { echo "batch: sbatch answered '$submitted', not a job id" >&2; exit 1; }
  submitted=$(sbatch --parsable --job-name svbrdf-summary --dependency "afterany:$jobid" --cpus-per-task 1 \
    --mem 256M --time 5 --chdir "$out" --output "$out/logs/summary.out" "${extra[@]}" \
    --export "ALL,SVBRDF=$SVBRDF" "$0" --summarize "$out")
  sumid=${submitted%%;*}
  [[ "$sumid" =~ ^[0-9]+$ ]] || { echo "batch: sbatch answered '$submitted', not a job id" >&2; exit 1; }
  echo "$jobid" > "$out/slurm_job_ids"
  echo "$sumid" >> "$out/slurm_job_ids"
  echo "batch: submitted array job $jobid ($n tasks) and its summary job $sumid; results in $out/summary.md" >&2
  [ "$wait" -eq 1 ] || exit 0

  # Wait until both jobs have left the queue. squeue lists only pending and
  # running jobs; once slurmctld forgot a job (MinJobAge after its end) it
  # answers "Invalid job id", which means done too. Other errors (slurmctld
  # briefly unreachable) are retried for 5 minutes.
  failing_since=""
  while :; do
    rc=0
    left=$(squeue --noheader --jobs "$jobid,$sumid" --format "%i %T %r" 2>&1) || rc=$?
    if [ "$rc" -ne 0 ]; then
      if [[ "$left" == *"Invalid job id"* ]]; then break; fi
      failing_since=${failing_since:-$SECONDS}
      [ $((SECONDS - failing_since)) -lt 300 ] ||
        { echo "batch: squeue has failed for 5 minutes: $left" >&2; exit 1; }
    else
      failing_since=""
      [ -n "$left" ] || break
      if [[ "$left" == *DependencyNeverSatisfied* ]]; then
        echo "batch: the summary job $sumid can never start: $left" >&2; exit 1
      fi
    fi
    sleep "$poll"
  done
  [ -f "$out/summary.json" ] && [ -f "$out/summary.md" ] ||
    { echo "batch: the summary job $sumid wrote no $out/summary.md (see $out/logs/summary.out)" >&2; exit 1; }
  cat "$out/summary.md"
  failed=$(/usr/bin/python3 -c 'import json, sys; print(sum(r.get("exit_code") != 0 for r in json.load(open(sys.argv[1]))))' \
    "$out/summary.json")
  [ "$failed" -eq 0 ] || { echo "batch: $failed of $n captures failed (logs: $out/logs/)" >&2; exit 1; }
  exit 0
fi

# Local: the same task script, one capture after another.
failed=0
for ((i = 0; i < n; ++i)); do
  SLURM_ARRAY_TASK_ID=$i run_task "$out" "$i" "$@" || failed=$((failed + 1))
done
summarize "$out"
[ "$failed" -eq 0 ] || { echo "batch: $failed of $n captures failed" >&2; exit 1; }
