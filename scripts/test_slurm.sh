#!/usr/bin/env bash
# Integration test of `scripts/batch.sh --slurm` against a real single-node Slurm.
#
# Starts its own slurmctld and slurmd (Debian 12 slurm-wlm, AuthType=auth/none,
# no munge, no cgroups) from a slurm.conf in a temporary folder, on free
# non-default ports, so it never talks to a system Slurm; waits until the node
# is idle; synthesizes two tiny captures; runs
#   scripts/batch.sh CAPTURES OUT --slurm --wait ...
# and checks every array task's material, report, timing and held-out score,
# the summary job's summary.md/json ("2 of 2 captures done") and the Slurm
# logs; then a capture that cannot be reconstructed must make batch.sh --wait
# (choosing Slurm by itself) exit 1 with the failure in its summary. The daemons are stopped and the
# folder removed on any exit (KEEP_SLURM_TMP=1 keeps the folder).
#
# Usage: scripts/test_slurm.sh [path/to/svbrdf]   (default build/apps/svbrdf)
# Exit: 0 pass, 1 fail, 77 skip (Slurm missing and not installable, or its
# daemons cannot start here). As root with apt-get, a missing slurm-wlm is
# installed (SLURM_TEST_NO_INSTALL=1: never). The recipe is explained in
# docs/guide/slurm.md.
set -euo pipefail
ROOT="$(cd "$(dirname "$0")/.." && pwd)"
SVBRDF="${1:-$ROOT/build/apps/svbrdf}"
export PATH="$PATH:/usr/sbin:/sbin"
T0=$SECONDS

say() { echo "test_slurm [$((SECONDS - T0)) s]: $*" >&2; }
skip() { echo "test_slurm: SKIP: $*" >&2; exit 77; }
fail() { echo "test_slurm: FAIL: $*" >&2; exit 1; }

[ -x "$SVBRDF" ] || fail "no svbrdf binary at $SVBRDF (build first: bash scripts/setup.sh)"
SVBRDF="$(cd "$(dirname "$SVBRDF")" && pwd)/$(basename "$SVBRDF")"
[ -x /usr/bin/time ] || skip "/usr/bin/time is missing (apt-get install time); batch.sh needs it"

# --- Slurm binaries: install slurm-wlm when missing and apt is at hand -------
BINS=(slurmctld slurmd sbatch squeue sinfo scancel scontrol)
have_slurm() { local b; for b in "${BINS[@]}"; do command -v "$b" > /dev/null || return 1; done; }
if ! have_slurm; then
  if [ "$(id -u)" -eq 0 ] && command -v apt-get > /dev/null && [ -z "${SLURM_TEST_NO_INSTALL:-}" ]; then
    say "installing slurm-wlm (apt-get)"
    apt_log=$(mktemp)
    if ! { apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq \
      --no-install-recommends slurm-wlm; } > "$apt_log" 2>&1; then
      tail -n 20 "$apt_log" >&2; rm -f "$apt_log"
      skip "Slurm is not installed and 'apt-get install slurm-wlm' failed"
    fi
    rm -f "$apt_log"
  fi
  have_slurm || skip "Slurm is not installed (no ${BINS[*]} on PATH; apt-get install slurm-wlm)"
fi

# --- a private Slurm in a temporary folder ------------------------------------
TMP="$(mktemp -d "${TMPDIR:-/tmp}/svbrdf-slurm.XXXXXX")"
chmod 755 "$TMP"
CTL_PID="" SLURMD_PID=""
stop_pid() {  # stop_pid PID: TERM, up to 10 s, then KILL
  local pid=$1 i
  [ -n "$pid" ] && kill -0 "$pid" 2> /dev/null || return 0
  kill -TERM "$pid" 2> /dev/null || true
  for ((i = 0; i < 50; ++i)); do kill -0 "$pid" 2> /dev/null || break; sleep 0.2; done
  kill -0 "$pid" 2> /dev/null && kill -KILL "$pid" 2> /dev/null || true
  wait "$pid" 2> /dev/null || true
}
cleanup() {
  local rc=$? i
  set +e
  if [ -n "$CTL_PID" ] && kill -0 "$CTL_PID" 2> /dev/null; then
    # Our controller's jobs only (SLURM_CONF points at it): cancel, and let
    # slurmd end their steps before it stops.
    scancel --partition svbrdf > /dev/null 2>&1
    for ((i = 0; i < 30; ++i)); do
      [ -z "$(squeue --noheader 2> /dev/null)" ] && break
      sleep 0.5
    done
  fi
  stop_pid "$SLURMD_PID"
  stop_pid "$CTL_PID"
  if [ "$rc" -ne 0 ] && [ "$rc" -ne 77 ]; then
    for f in "$TMP"/slurmctld.log "$TMP"/slurmd.log "$TMP"/batch*.log; do
      [ -f "$f" ] && { echo "--- last lines of $f" >&2; tail -n 25 "$f" >&2; }
    done
  fi
  if [ -n "${KEEP_SLURM_TMP:-}" ]; then echo "test_slurm: kept $TMP" >&2; else rm -rf "$TMP"; fi
  exit "$rc"
}
trap cleanup EXIT
trap 'exit 130' INT
trap 'exit 143' TERM

# Two free TCP ports (the system Slurm's are 6817/6818).
read -r CTL_PORT SLURMD_PORT < <(python3 - <<'EOF'
import socket
socks = [socket.socket() for _ in range(2)]
for s in socks:
    s.bind(("127.0.0.1", 0))
print(*(s.getsockname()[1] for s in socks))
EOF
)
# The node as slurmd sees it (CPUs, sockets, cores, threads, memory), so the
# configuration never claims more than the machine has.
HW="$(slurmd -C 2> /dev/null | head -n 1 | tr ' ' '\n' |
  grep -E '^(CPUs|Boards|SocketsPerBoard|CoresPerSocket|ThreadsPerCore|RealMemory)=' | tr '\n' ' ' || true)"
[[ "$HW" == *CPUs=* && "$HW" == *RealMemory=* ]] ||
  HW="CPUs=$(nproc) RealMemory=$(awk '/^MemTotal:/ { print int($2 / 1024) }' /proc/meminfo)"
USER_NAME="$(id -un)"
mkdir -p "$TMP/state" "$TMP/spool"
export SLURM_CONF="$TMP/slurm.conf"
cat > "$SLURM_CONF" <<EOF
# Single-node Slurm of scripts/test_slurm.sh (see docs/guide/slurm.md).
ClusterName=svbrdftest
SlurmctldHost=localhost
SlurmctldPort=$CTL_PORT
SlurmdPort=$SLURMD_PORT
SlurmUser=$USER_NAME
SlurmdUser=$USER_NAME
AuthType=auth/none
CredType=cred/none
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
MpiDefault=none
MailProg=/bin/true
SelectType=select/cons_tres
SelectTypeParameters=CR_Core_Memory
SchedulerType=sched/builtin
ReturnToService=2
AccountingStorageType=accounting_storage/none
JobAcctGatherType=jobacct_gather/none
JobCompType=jobcomp/none
StateSaveLocation=$TMP/state
SlurmdSpoolDir=$TMP/spool
SlurmctldPidFile=$TMP/slurmctld.pid
SlurmdPidFile=$TMP/slurmd.pid
SlurmctldLogFile=$TMP/slurmctld.log
SlurmdLogFile=$TMP/slurmd.log
SlurmctldDebug=info
SlurmdDebug=info
NodeName=svbrdfnode NodeHostname=localhost NodeAddr=127.0.0.1 $HW State=UNKNOWN
PartitionName=svbrdf Nodes=svbrdfnode Default=YES MaxTime=INFINITE State=UP
EOF
say "slurm.conf in $TMP (ports $CTL_PORT/$SLURMD_PORT; node $HW)"

slurmctld -D -c -f "$SLURM_CONF" > "$TMP/slurmctld.out" 2>&1 &
CTL_PID=$!
slurmd -D -N svbrdfnode -f "$SLURM_CONF" > "$TMP/slurmd.out" 2>&1 &
SLURMD_PID=$!

# Wait until the node is idle (daemons that die or never register: skip).
why_not() {  # the daemons' last errors (their log files, else what they printed)
  local d f
  for d in slurmctld slurmd; do
    f="$TMP/$d.log"; [ -s "$f" ] || f="$TMP/$d.out"
    [ -s "$f" ] && { echo "--- $f:"; grep -iE 'error|fatal' "$f" | tail -n 5 || tail -n 5 "$f"; }
  done
  return 0
}
state=""
for ((i = 0; i < 120; ++i)); do
  kill -0 "$CTL_PID" 2> /dev/null || skip "slurmctld could not start here:
$(why_not)"
  kill -0 "$SLURMD_PID" 2> /dev/null || skip "slurmd could not start here:
$(why_not)"
  state="$(sinfo --noheader --nodes svbrdfnode --format %T 2> /dev/null || true)"
  [ "$state" = idle ] && break
  case "$state" in inval|drain*|fail*) break;; esac  # slurmctld rejected the node's hardware
  sleep 0.5
done
[ "$state" = idle ] || skip "the node did not become idle (state '${state:-no answer}'):
$(sinfo -R 2> /dev/null)
$(why_not)"
say "slurmctld $CTL_PID and slurmd $SLURMD_PID up, node idle"

# --- two tiny captures, reconstructed as an array job -------------------------
CAPS="$TMP/captures"
for c in a:3 b:4; do
  "$SVBRDF" synth --preset tiny --width 80 --height 60 --images 12 --seed "${c#*:}" \
    --out "$CAPS/cap_${c%%:*}" > "$TMP/synth.log" 2>&1 || { cat "$TMP/synth.log" >&2; fail "svbrdf synth failed"; }
done
say "synthesized $CAPS/cap_a and cap_b; running batch.sh --slurm --wait"
OUT="$TMP/out"
cd "$TMP"
rc=0
SVBRDF="$SVBRDF" timeout 300 bash "$ROOT/scripts/batch.sh" "$CAPS" "$OUT" --slurm --wait --poll 1 \
  --partition svbrdf --cpus 1 --mem 256M --time-limit 5 --relight "--spp 1" \
  -- --max-clusters 2 --normals off --time-budget 2 > "$TMP/batch.log" 2>&1 || rc=$?
cat "$TMP/batch.log" >&2
[ "$rc" -eq 0 ] || fail "batch.sh --slurm --wait exited $rc"
say "array job done"

{ read -r JOB; read -r SUMJOB; } < "$OUT/slurm_job_ids"
[[ "$JOB" =~ ^[0-9]+$ && "$SUMJOB" =~ ^[0-9]+$ ]] || fail "no job ids in $OUT/slurm_job_ids"
if [ -n "$(squeue --noheader --jobs "$JOB,$SUMJOB" 2> /dev/null)" ]; then
  fail "jobs $JOB/$SUMJOB still queued after --wait"
fi
errors=0
check() { [ "$@" ] || { echo "test_slurm: not true: [ $* ]" >&2; errors=$((errors + 1)); }; }
i=0
for cap in cap_a cap_b; do
  d="$OUT/$cap"
  check -f "$d/exit_code"
  check "$(cat "$d/exit_code" 2> /dev/null)" = 0
  check -s "$d/material/material.json"
  check -s "$d/material/report/summary.json"
  check -s "$d/material/report/report.html"
  check -s "$d/time.txt"
  grep -q "mean PSNR" "$d/evaluate.txt" 2> /dev/null || check "no mean PSNR in $d/evaluate.txt" = ""
  log="$OUT/logs/${JOB}_$i.out"
  grep -q "\[task $i\] $cap: exit 0" "$log" 2> /dev/null || check "no '[task $i] $cap: exit 0' in $log" = ""
  i=$((i + 1))
done
check -s "$OUT/logs/summary.out"
grep -q "2 of 2 captures done" "$OUT/summary.md" 2> /dev/null || check "no '2 of 2 captures done' in summary.md" = ""
python3 - "$OUT/summary.json" <<'EOF' || check "summary.json" = "as expected"
import json, sys
rows = json.load(open(sys.argv[1]))
assert [r["capture"] for r in rows] == ["cap_a", "cap_b"], rows
for r in rows:
    assert r["exit_code"] == 0, r
    assert r.get("clusters", 0) >= 1, r
    assert r.get("heldout_psnr_db", 0) > 15, r
    assert r.get("wall_s", 0) > 0 and r.get("peak_mb", 0) > 0, r
EOF
[ "$errors" -eq 0 ] || fail "$errors checks of the array job's outputs failed (outputs in $OUT)"
say "both tasks wrote material, report, time and held-out score; summary: 2 of 2 done"

# --- a capture that fails must fail batch.sh --wait ----------------------------
# (no --slurm: the default must find the answering controller; --threads after
# -- replaces the task's own)
mkdir -p "$TMP/bad/cap_bad"
echo '{"images": "not a list"}' > "$TMP/bad/cap_bad/scene.json"
rc=0
SVBRDF="$SVBRDF" timeout 120 bash "$ROOT/scripts/batch.sh" "$TMP/bad" "$TMP/out_bad" --wait --poll 1 \
  --partition svbrdf --cpus 1 --mem 256M --time-limit 2 -- --threads 1 > "$TMP/batch_bad.log" 2>&1 || rc=$?
[ "$rc" -eq 1 ] || { cat "$TMP/batch_bad.log" >&2; fail "batch.sh with a broken capture exited $rc, not 1"; }
grep -q "1 captures, slurm" "$TMP/batch_bad.log" || { cat "$TMP/batch_bad.log" >&2; fail "batch.sh did not choose Slurm"; }
grep -q "1 of 1 captures failed" "$TMP/batch_bad.log" || { cat "$TMP/batch_bad.log" >&2; fail "no failure count"; }
bad_rc="$(cat "$TMP/out_bad/cap_bad/exit_code" 2> /dev/null || echo none)"
[ "$bad_rc" != 0 ] && [ "$bad_rc" != none ] || fail "the broken capture's exit_code is '$bad_rc'"
grep -q "| cap_bad | $bad_rc |" "$TMP/out_bad/summary.md" || fail "summary.md misses the failed capture"
say "a broken capture fails batch.sh --wait (exit 1, reconstruct exit $bad_rc in summary.md)"

echo "test_slurm: PASS in $((SECONDS - T0)) s"
