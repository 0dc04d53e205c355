# Shared by the MiRo scripts: a scratch folder, processes stopped on exit, free loopback
# ports, waiting on the server's HTTP API. Sourced, not run.
TMP="$(mktemp -d)"
PIDS=()
cleanup() {
  local pid
  for pid in "${PIDS[@]}"; do kill "$pid" 2>/dev/null || true; done
  for pid in "${PIDS[@]}"; do wait "$pid" 2>/dev/null || true; done
  if [ -n "${KEEP_LOGS:-}" ]; then mkdir -p "$KEEP_LOGS" && cp "$TMP"/*.log "$KEEP_LOGS"/ 2>/dev/null || true; fi
  rm -rf "$TMP"
}
trap cleanup EXIT
trap 'exit 130' INT TERM

fail() {
  echo "$NAME: FAILED: $*" >&2
  for f in "$TMP"/*.log; do
    [ -f "$f" ] || continue
    echo "--- $(basename "$f") (last 30 lines)" >&2
    tail -n 30 "$f" >&2
  done
  exit 1
}

free_port() {
  python3 -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1",0)); print(s.getsockname()[1])'
}

# http_get URL: the body, or nothing when the server does not answer.
http_get() {
  python3 - "$1" <<'PY' 2>/dev/null || true
import sys, urllib.request
try:
    print(urllib.request.urlopen(sys.argv[1], timeout=2).read().decode())
except Exception:
    pass
PY
}

# metric NAME: its value from the server's /metrics (0 when absent).
metric() {
  http_get "http://127.0.0.1:$HTTP_PORT/metrics" | awk -v n="$1" '$1 == n { print $2; found=1 } END { if (!found) print 0 }'
}

# contributors: the robots that fused into the served ball, comma-separated.
contributors() {
  http_get "http://127.0.0.1:$HTTP_PORT/api/state" | python3 -c '
import json, sys
try:
    s = json.load(sys.stdin)
except Exception:
    sys.exit(0)
b = s.get("ball") or {}
print(",".join(b.get("contributors") or []))'
}

# start_server: the fusion server on loopback ports of its own, open network.
start_server() {
  ZENOH_PORT="$(free_port)"
  HTTP_PORT="$(free_port)"
  "$FUSION_SERVER" serve --open --listen "tcp/127.0.0.1:$ZENOH_PORT" --http "127.0.0.1:$HTTP_PORT" \
    > "$TMP/server.log" 2>&1 &
  PIDS+=($!)
  for _ in $(seq 1 100); do
    [ -n "$(http_get "http://127.0.0.1:$HTTP_PORT/api/state")" ] && return 0
    sleep 0.1
  done
  fail "the server did not answer on 127.0.0.1:$HTTP_PORT"
}

# wait_for_ball ROBOT MIN_ACCEPTED SECONDS: until ROBOT fused into the served ball and the
# server accepted at least MIN_ACCEPTED observations.
wait_for_ball() {
  local deadline=$((SECONDS + $3)) accepted
  while [ "$SECONDS" -lt "$deadline" ]; do
    accepted="$(metric rf_observations_accepted_total)"
    if [[ ",$(contributors)," == *",$1,"* ]] && awk -v a="$accepted" -v m="$2" 'BEGIN { exit !(a >= m) }'; then
      echo "$NAME: the server serves the ball from $1 ($accepted observations accepted)"
      return 0
    fi
    sleep 0.5
  done
  fail "no ball from $1 served within $3 s ($(metric rf_observations_accepted_total) observations accepted)"
}

# record_frames DIR: a simulated MiRo's two cameras over a match, as an image folder.
record_frames() {
  "$SIM_AGENT" run --robot-id miro1 --offline --scenario seed-1-across --seed 2 --fast \
    --record-frames "$1" > "$TMP/record.log" 2>&1 || fail "recording frames"
}

# summary LOG: "FRAMES OBSERVATIONS" of an agent's summary line.
summary() {
  awk '$1 == "miro1:" && $3 == "frames," { print $2, $4; exit }' "$1"
}

# runner_for BIN: sets RUNNER to the qemu-user emulator BIN needs here (none for this
# machine's own architecture), from its ELF header's machine field.
runner_for() {
  local machine
  machine="$(od -An -tx1 -j18 -N2 "$1" | tr -d ' \n')"
  case "$machine" in
    2800) RUNNER=(qemu-arm) ;;
    b700) RUNNER=(qemu-aarch64) ;;
    *) RUNNER=() ;;
  esac
}
