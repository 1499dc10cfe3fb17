#!/usr/bin/env bash
# Ctrl-C on every long command: start it on work that runs far longer than the wait, send SIGINT once
# it is under way, and print the time from the signal to the exit, the exit code (130 expected) and
# whether the previous results at its output folder were kept.
#
#   bash scripts/interrupt-times.sh [ROUNDS]
#
# Uses target/release/brachia (or $BRACHIA); build it first with `cargo build --release -p brachia-cli`.
# Run from the repository root. Prints one Markdown table row per command and round.
set -euo pipefail
ROOT=$(cd "$(dirname "$0")/.." && pwd)
cd "$ROOT"
BIN=${BRACHIA:-${CARGO_TARGET_DIR:-$ROOT/target}/release/brachia}
ROUNDS=${1:-1}
[ -x "$BIN" ] || { echo "no binary at $BIN: cargo build --release -p brachia-cli" >&2; exit 2; }
WORK=$(mktemp -d)
trap 'rm -rf "$WORK"' EXIT

# scenarios of work that cannot finish before the signal
cat > "$WORK/free.toml" <<TOML
params = "$ROOT/params/paper.toml"
[task]
q0 = [-2.35, 0.0, -1.55, 0.0]
target = [0.8, 0.0]
[planner]
swing_time = 20.0
knot_dt = 0.01
transcription = "multiple-shooting"
free_swing_time = [10.0, 20.0]
swing_time_starts = 16
[solver]
backend = "ocp"
TOML
{
  echo 'name = "twelve-link"'
  echo 'gravity = 9.81'
  for _ in $(seq 12); do
    printf '[[links]]\nlength = 0.1\nmass = 0.15\ncom = 0.05\ninertia = 0.0002\nradius = 0.01\n'
  done
  echo '[actuators]'
  echo "tau_min = [$(printf -- '-3.0,%.0s' $(seq 10))-3.0]"
  echo "tau_max = [$(printf -- '3.0,%.0s' $(seq 10))3.0]"
} > "$WORK/twelve.toml"
cat > "$WORK/hs12.toml" <<TOML
params = "$WORK/twelve.toml"
[task]
q0 = [-2.35, 0.0, -0.3, 0.0, -0.3, 0.0, -0.3, 0.0, -0.3, 0.0, -0.3, 0.0]
target = [0.7, 0.0]
[planner]
swing_time = 4.0
knot_dt = 0.02
transcription = "hermite-simpson"
[solver]
backend = "pounce"
TOML
cat > "$WORK/hold.toml" <<TOML
params = "$ROOT/params/paper.toml"
[task]
q0 = [-2.35, 0.0, -1.55, 0.0]
target = [0.8, 0.0]
[planner]
swing_time = "auto"
knot_dt = 0.03
transcription = "multiple-shooting"
[solver]
backend = "ocp"
[tracking]
hold_s = 60.0
TOML
cat > "$WORK/long8.toml" <<TOML
params = "$ROOT/params/paper.toml"
[task]
q0 = [-2.35, 0.0, -1.55, 0.0]
target = [0.8, 0.0]
[planner]
swing_time = 8.0
knot_dt = 0.03
transcription = "multiple-shooting"
[solver]
backend = "ocp"
max_iter = 3
TOML
# a plan folder to draw (an 8 s swing stopped after 3 iterations: exit 1, its folder written) and a
# plan to track
"$BIN" plan --scenario "$WORK/long8.toml" --out "$WORK/plan8" 2>/dev/null || true
"$BIN" plan --scenario scenarios/tracking.toml --out "$WORK/plan" 2>/dev/null

# previous results: a run folder with a result listed in its manifest and a file of the user's
previous() {
  rm -rf "$1"; mkdir -p "$1"
  printf '# brachia run folder\nreport.json\n' > "$1/.brachia-run"
  echo previous > "$1/report.json"; echo mine > "$1/notes.txt"
}
kept() {
  [ "$(cat "$1/report.json")" = previous ] && [ "$(cat "$1/notes.txt")" = mine ] \
    && [ -z "$(find "$1" "$(dirname "$1")" -maxdepth 1 -name '.*partial*' -o -maxdepth 1 -name '.*.tmp')" ] \
    && echo yes || echo NO
}
now() { date +%s.%N; }
# every entry of the plan folder drawn by `report` (name, size, time), to compare before and after
snapshot() { find "$WORK/plan8" -type f -printf '%p %s %T@\n' | sort | md5sum; }

# measure NAME DELAY_S OUT_OR_- COMMAND...: one table row
measure() {
  local name=$1 delay=$2 out=$3; shift 3
  [ "$out" = - ] || previous "$out"
  local before=""
  [ "$out" = - ] && before=$(snapshot)
  "$@" >/dev/null 2>"$WORK/stderr" &
  local pid=$!
  sleep "$delay"
  if ! kill -0 "$pid" 2>/dev/null; then
    wait "$pid" || true
    echo "| $name | finished before the signal | - | - |"; return
  fi
  local t0; t0=$(now)
  kill -INT "$pid"
  local code=0
  wait "$pid" || code=$?
  local t1; t1=$(now)
  local ok
  if [ "$out" = - ]; then
    [ "$(snapshot)" = "$before" ] && ok=yes || ok=NO
  else
    ok=$(kept "$out")
  fi
  printf '| %s | %s | %.2f s | %s |\n' "$name" "$code" "$(echo "$t1 - $t0" | bc -l)" "$ok"
}

echo "| command | exit | SIGINT to exit | previous results kept |"
echo "|---|---|---|---|"
for _ in $(seq "$ROUNDS"); do
  measure "plan, free swing time, 16 starts" 2 "$WORK/o1" "$BIN" plan --scenario "$WORK/free.toml" --out "$WORK/o1"
  measure "plan, 12 links, Hermite-Simpson (pounce), no time limit" 8 "$WORK/o2" "$BIN" plan --scenario "$WORK/hs12.toml" --out "$WORK/o2"
  measure "track, MPC, model plant (60 s hold)" 3 "$WORK/o3" "$BIN" track --scenario "$WORK/hold.toml" --plan "$WORK/plan" --out "$WORK/o3"
  measure "track, MPC, rapier plant (60 s hold)" 3 "$WORK/o4" "$BIN" track --scenario "$WORK/hold.toml" --plan "$WORK/plan" --plant rapier --out "$WORK/o4"
  measure "simulate, 600 s" 1 "$WORK/o5" "$BIN" simulate --params params/paper.toml --q0=-2.35,0,-1.55,0 --duration 600 --out "$WORK/o5"
  measure "traverse, scenarios/ladder-even.toml" 3 "$WORK/o6" "$BIN" traverse --scenario scenarios/ladder-even.toml --out "$WORK/o6"
  measure "benchmark --quick" 3 "$WORK/o7" "$BIN" benchmark --scenario scenarios/tracking.toml --quick --no-progress --out "$WORK/o7"
  measure "reproduce --quick" 3 "$WORK/o8" "$BIN" reproduce --quick --no-progress --out "$WORK/o8"
  measure "report of an 8 s plan folder (in its animation)" 0.4 - "$BIN" report "$WORK/plan8"
  # view does no long work: it is timed, not interrupted
  t0=$(now); "$BIN" view "$WORK/plan8" 2>/dev/null; t1=$(now)
  printf '| view of an 8 s plan folder | 0 | finishes in %.2f s | - |\n' "$(echo "$t1 - $t0" | bc -l)"
done
