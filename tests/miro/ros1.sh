#!/usr/bin/env bash
# `robot-agent run --source ros1` against Debian's real ROS 1 master: a publisher plays a
# recorded MiRo's frames, joints and pose as the robot's own topics; the agent reads them
# with no bridge and publishes to a native fusion server, which serves the ball. Then the
# master and the publisher go away (the agent logs it and keeps running), the master comes
# back with a publisher of the wrong type on the joints topic (refused with a log line
# naming both types), and then the right publisher: the ball is served again.
#
#   AGENT=target/debug/robot-agent FUSION_SERVER=target/debug/fusion-server \
#   SIM_AGENT=target/debug/sim_agent tests/miro/ros1.sh
#
# AGENT may be a cross-built agent (it then runs under qemu-user). Installs Debian's ROS 1
# master and Python client (python3-rosmaster, python3-rospy, python3-sensor-msgs,
# python3-geometry-msgs) if missing.
set -euo pipefail
NAME=ros1
cd "$(dirname "$0")/../.."
: "${AGENT:?set AGENT to the robot-agent binary}"
: "${FUSION_SERVER:?set FUSION_SERVER to the fusion-server binary}"
: "${SIM_AGENT:?set SIM_AGENT to the sim_agent binary}"

if ! command -v rosmaster >/dev/null || ! /usr/bin/python3 -c 'import rospy, sensor_msgs.msg, geometry_msgs.msg' 2>/dev/null; then
  SUDO=""
  if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
  $SUDO apt-get update -q
  $SUDO env DEBIAN_FRONTEND=noninteractive apt-get install -y -q --no-install-recommends \
    python3-rosmaster python3-rospy python3-sensor-msgs python3-geometry-msgs
fi
source tests/miro/common.sh
runner_for "$AGENT"

record_frames "$TMP/frames"
MASTER_PORT="$(free_port)"
export ROS_MASTER_URI="http://127.0.0.1:$MASTER_PORT" ROS_IP=127.0.0.1 ROS_HOME="$TMP/ros"

start_master() {
  rosmaster --core -p "$MASTER_PORT" >> "$TMP/master.log" 2>&1 &
  MASTER_PID=$!
  PIDS+=("$MASTER_PID")
}
# play [--wrong-type]: the publisher, for ever, in the background.
play() {
  /usr/bin/python3 tests/miro/play_miro_topics.py "$TMP/frames" --loops 0 "$@" >> "$TMP/player.log" 2>&1 &
  PLAYER_PID=$!
  PIDS+=("$PLAYER_PID")
}
# wait_log TEXT SECONDS: until the agent's log says TEXT.
wait_log() {
  local deadline=$((SECONDS + $2))
  while [ "$SECONDS" -lt "$deadline" ]; do
    grep -qF -- "$1" "$TMP/agent.log" && return 0
    sleep 0.2
  done
  fail "the agent did not log \"$1\" within $2 s"
}

start_master
start_server
# The agent first, before the master answers: it waits for it.
"${RUNNER[@]}" "$AGENT" run --source ros1 --robot-id miro1 --connect "tcp/127.0.0.1:$ZENOH_PORT" \
  > "$TMP/agent.log" 2>&1 &
PIDS+=($!)
AGENT_PID=$!
play
wait_for_ball miro1 20 60
wait_log "reading from http://127.0.0.1:" 5

# The master and the publisher go away; the agent says so and keeps running.
kill "$MASTER_PID" "$PLAYER_PID"
wait "$MASTER_PID" "$PLAYER_PID" 2>/dev/null || true
wait_log "does not answer" 10
kill -0 "$AGENT_PID" 2>/dev/null || fail "the agent stopped with its master"

# Back, with the wrong type on the joints topic first.
start_master
play --wrong-type
wait_log "is back: subscribed to" 15
wait_log 'carries "std_msgs/String"' 15
kill "$PLAYER_PID"; wait "$PLAYER_PID" 2>/dev/null || true
before="$(metric rf_observations_accepted_total)"
play
wait_for_ball miro1 "$((${before%.*} + 20))" 60
kill -0 "$AGENT_PID" 2>/dev/null || fail "the agent stopped"
grep -q "panicked" "$TMP/agent.log" "$TMP/server.log" && fail "a panic in the logs"
echo "$NAME: passed"
