#!/usr/bin/env bash
# Tests of the Python ball client (clients/python) against real processes.
#
#   FUSION_SERVER=path/to/fusion-server SIM_ROBOTS=path/to/sim_robots clients/python/run-tests.sh
#
# It makes (or reuses) a virtual environment at ${CLIENT_VENV:-target/python-venv} (relative
# to the repository's root), installs eclipse-zenoh==1.10.2 and the package into it, then
# starts on loopback ports it picks:
#   - an open-network fusion server with three simulated robots;
#   - a secured one (keys made by `fusion-server keys` in a temporary folder, the server
#     with --tls and a roster, two simulated robots with --keys);
#   - a router (tests/zenoh_router.py, loading the zenohd.json5 `fusion-server keys`
#     writes) with a secured server behind it that has no robots, so no ball;
# and runs tests/run_all.py against them, also against an endpoint where nothing listens.
# Everything it started is stopped on exit, whatever happens. PYTHON picks the interpreter
# (default python3, at least 3.9).
set -euo pipefail

here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
root="$(cd "$here/../.." && pwd)"

die() { echo "run-tests.sh: $*" >&2; exit 2; }

for var in FUSION_SERVER SIM_ROBOTS; do
    bin="${!var:-}"
    [[ -n "$bin" ]] || die "$var is not set: give the path of the $( [[ $var == FUSION_SERVER ]] && echo fusion-server || echo sim_robots ) program (e.g. target/release/...)"
    [[ -x "$bin" && -f "$bin" ]] || die "$var=$bin is not an executable file"
done
FUSION_SERVER="$(cd "$(dirname "$FUSION_SERVER")" && pwd)/$(basename "$FUSION_SERVER")"
SIM_ROBOTS="$(cd "$(dirname "$SIM_ROBOTS")" && pwd)/$(basename "$SIM_ROBOTS")"

venv="${CLIENT_VENV:-target/python-venv}"
[[ "$venv" == /* ]] || venv="$root/$venv"
python="${PYTHON:-python3}"

work="$(mktemp -d "${TMPDIR:-/tmp}/miro-ball-tests.XXXXXX")"
pids=()
tests_pid=""

cleanup() {
    local status=$?
    trap - EXIT INT TERM
    local pid
    # `timeout` leads its own process group: the tests and any server a test started.
    [[ -n "$tests_pid" ]] && kill -- "-$tests_pid" 2>/dev/null || true
    for pid in ${pids[@]+"${pids[@]}"}; do
        kill "$pid" 2>/dev/null || true
    done
    for _ in $(seq 30); do
        local alive=0
        for pid in ${pids[@]+"${pids[@]}"}; do
            if kill -0 "$pid" 2>/dev/null; then alive=1; fi
        done
        (( alive )) || break
        sleep 0.1
    done
    [[ -n "$tests_pid" ]] && kill -9 -- "-$tests_pid" 2>/dev/null || true
    for pid in ${pids[@]+"${pids[@]}"}; do
        kill -9 "$pid" 2>/dev/null || true
        wait "$pid" 2>/dev/null || true
    done
    rm -rf "$work"
    exit "$status"
}
trap cleanup EXIT
trap 'exit 130' INT
trap 'exit 143' TERM

started=$(date +%s)

# --- the virtual environment ------------------------------------------------------------
if [[ ! -x "$venv/bin/python" ]]; then
    "$python" -c 'import sys; sys.exit(0 if sys.version_info >= (3, 9) else 1)' \
        || die "$python is older than Python 3.9"
    echo "making the virtual environment $venv"
    "$python" -m venv "$venv"
fi
vpy="$venv/bin/python"
if ! "$vpy" - <<'EOF'
import sys
from importlib.metadata import version, PackageNotFoundError
try:
    ok = version("eclipse-zenoh") == "1.10.2" and int(version("setuptools").split(".")[0]) >= 71
except PackageNotFoundError:
    ok = False
sys.exit(0 if ok else 1)
EOF
then
    echo "installing eclipse-zenoh==1.10.2 into $venv"
    "$vpy" -m pip install --quiet --disable-pip-version-check "eclipse-zenoh==1.10.2" "setuptools>=71"
fi
# Built from a copy, so that nothing is written into the source folder.
mkdir -p "$work/pkg"
cp -R "$here/pyproject.toml" "$here/README.md" "$here/src" "$work/pkg/"
"$vpy" -m pip install --quiet --disable-pip-version-check --no-deps --no-build-isolation \
    --force-reinstall "$work/pkg" >"$work/pip.log" 2>&1 || { cat "$work/pip.log" >&2; die "installing the package failed"; }

# --- ports, keys and processes ----------------------------------------------------------
read -r open_z open_http tls_z tls_http dead_z router_z router_http < <("$vpy" - <<'EOF'
import socket
socks = [socket.socket() for _ in range(7)]
for s in socks:
    s.bind(("127.0.0.1", 0))
print(*[s.getsockname()[1] for s in socks])
for s in socks:
    s.close()
EOF
)

"$FUSION_SERVER" keys --out "$work/keys" --robots miro1,miro2,intruder --servers s1,s2 \
    --routers r1 --router-listen "tls/127.0.0.1:$router_z" >"$work/keys.log" 2>&1 \
    || { cat "$work/keys.log" >&2; die "fusion-server keys failed"; }
"$FUSION_SERVER" keys --out "$work/other-keys" --robots miro1 >"$work/other-keys.log" 2>&1 \
    || { cat "$work/other-keys.log" >&2; die "fusion-server keys (another authority) failed"; }

start() {  # start NAME COMMAND...: runs it in the background, output in $work/NAME.{out,log}
    local name=$1
    shift
    "$@" >"$work/$name.out" 2>"$work/$name.log" &
    pids+=($!)
}

start open-server "$FUSION_SERVER" serve --open --id test-open \
    --listen "tcp/127.0.0.1:$open_z" --http "127.0.0.1:$open_http"
start tls-server "$FUSION_SERVER" serve --id s1 --tls "$work/keys/server-s1" --roster miro1,miro2 \
    --listen "tls/127.0.0.1:$tls_z" --http "127.0.0.1:$tls_http"

start router "$vpy" "$here/tests/zenoh_router.py" "$work/keys/router-r1/zenohd.json5"
for _ in $(seq 100); do
    grep -q '^router up' "$work/router.out" 2>/dev/null && break
    sleep 0.1
done
grep -q '^router up' "$work/router.out" || { cat "$work/router.out" "$work/router.log" >&2; die "the router did not start"; }
start routed-server "$FUSION_SERVER" serve --id s2 --tls "$work/keys/server-s2" --roster miro1,miro2 \
    --routers r1 --mode client --connect "tls/127.0.0.1:$router_z" --http "127.0.0.1:$router_http"

# A server prints its Zenoh endpoint on standard output once it listens (or connects).
for name in open-server tls-server routed-server; do
    for _ in $(seq 100); do
        grep -q '^zenoh ' "$work/$name.out" 2>/dev/null && break
        sleep 0.1
    done
    grep -q '^zenoh ' "$work/$name.out" 2>/dev/null || {
        cat "$work/$name.out" "$work/$name.log" >&2
        die "$name did not start"
    }
done

start open-robots "$SIM_ROBOTS" --connect "tcp/127.0.0.1:$open_z" \
    --scenario match --seed 2 --team-size 3 --duration-s 110
start tls-robots "$SIM_ROBOTS" --keys "$work/keys" --connect "tls/127.0.0.1:$tls_z" \
    --scenario match --seed 3 --team-size 2 --duration-s 110

# --- the tests --------------------------------------------------------------------------
export MIRO_BALL_REQUIRE_ALL=1
export MIRO_BALL_OPEN_ENDPOINT="tcp/127.0.0.1:$open_z"
export MIRO_BALL_OPEN_SERVER_ID=test-open
export MIRO_BALL_OPEN_ROBOTS=miro1,miro2,miro3
export MIRO_BALL_TLS_ENDPOINT="tls/127.0.0.1:$tls_z"
export MIRO_BALL_KEYS="$work/keys"
export MIRO_BALL_TLS_ROBOTS=miro1,miro2
export MIRO_BALL_INTRUDER=intruder
export MIRO_BALL_OTHER_KEYS="$work/other-keys/robot-miro1"
export MIRO_BALL_DEAD_ENDPOINT="tcp/127.0.0.1:$dead_z"
export MIRO_BALL_ROUTER_ENDPOINT="tls/127.0.0.1:$router_z"
export FUSION_SERVER  # a test starts (and stops) a server of its own

export PYTHONDONTWRITEBYTECODE=1  # no __pycache__ left in the source folder
status=0
# Run from the temporary folder: the tests import the installed package, not src/. In the
# background, so that an interrupt reaches the trap at once.
(cd "$work" && exec timeout --kill-after=5 100 "$vpy" "$here/tests/run_all.py") &
tests_pid=$!
pids+=("$tests_pid")
wait "$tests_pid" || status=$?

if (( status != 0 )); then
    for name in open-server tls-server open-robots tls-robots router routed-server; do
        echo "--- last lines of $name's log" >&2
        tail -n 15 "$work/$name.log" >&2 || true
    done
    (( status == 124 )) && echo "run-tests.sh: the tests did not finish within 100 s" >&2
fi
echo "run-tests.sh: finished in $(( $(date +%s) - started )) s"
exit "$status"
