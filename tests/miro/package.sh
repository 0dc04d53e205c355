#!/usr/bin/env bash
# The agent's Debian package: built from a robot-agent binary by robot-agent/deploy/build-deb,
# then linted (lintian, no error or warning), its contents and fields checked (dpkg-deb), its
# systemd unit verified (systemd-analyze verify, against the package's own files), and the
# settings it installs refused with exit status 78 and a message naming the key until
# robot_id and connect are set.
#
#   AGENT=target/cross/armv7-unknown-linux-gnueabihf/robot/robot-agent ARCH=armhf tests/miro/package.sh
#
# Installs lintian and systemd (for systemd-analyze) if missing. The package is left in target/deb/.
set -euo pipefail
NAME=package
cd "$(dirname "$0")/../.."
: "${AGENT:?set AGENT to the robot-agent binary to package}"
: "${ARCH:?set ARCH to the Debian architecture of AGENT (armhf, arm64, amd64)}"
if ! command -v lintian >/dev/null || ! command -v systemd-analyze >/dev/null; then
  SUDO=""
  if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
  $SUDO apt-get update -q
  $SUDO env DEBIAN_FRONTEND=noninteractive apt-get install -y -q --no-install-recommends lintian systemd
fi
source tests/miro/common.sh

deb="$(robot-agent/deploy/build-deb "$AGENT" "$ARCH")"
echo "$NAME: built $deb ($(du -h "$deb" | cut -f1))"

# Lint: no error and no warning (informational tags and the documented override aside).
lintian --fail-on error,warning --suppress-tags-from-file /dev/null "$deb" > "$TMP/lintian.log" 2>&1 \
  || fail "lintian: $(cat "$TMP/lintian.log")"
echo "$NAME: lintian: $(wc -l < "$TMP/lintian.log") notes, no error or warning"

# Fields and contents.
[ "$(dpkg-deb --field "$deb" Package)" = robot-agent ] || fail "Package field"
[ "$(dpkg-deb --field "$deb" Architecture)" = "$ARCH" ] || fail "Architecture field"
dpkg-deb --contents "$deb" > "$TMP/contents.log"
for f in ./usr/bin/robot-agent ./lib/systemd/system/robot-agent.service ./etc/robot-agent/agent.toml \
  ./usr/lib/sysusers.d/robot-agent.conf ./usr/share/doc/robot-agent/copyright \
  ./usr/share/man/man1/robot-agent.1.gz; do
  grep -q " $f\$" "$TMP/contents.log" || fail "$f is not in the package"
done
grep -q "rwxr-xr-x root/root .* ./usr/bin/robot-agent$" "$TMP/contents.log" || fail "the binary's mode or owner"
dpkg-deb --ctrl-tarfile "$deb" | tar -t > "$TMP/control.log"
grep -x "./conffiles" "$TMP/control.log" >/dev/null || fail "no conffiles"
[ "$(dpkg-deb --ctrl-tarfile "$deb" | tar -xO ./conffiles)" = /etc/robot-agent/agent.toml ] \
  || fail "the settings are not a conffile"

# The unit, verified against the package's own files.
root="$TMP/root"
mkdir -p "$root"
dpkg-deb --extract "$deb" "$root"
# systemd-analyze checks the unit's binary path inside --root (the package's own binary)
# and its dependencies among the units there: this machine's own targets are put beside it.
# The manual page named in Documentation= is the package's, checked by lintian.
cp -an /lib/systemd/system/. "$root/lib/systemd/system/"
systemd-analyze verify --man=no --root="$root" "$root/lib/systemd/system/robot-agent.service" \
  > "$TMP/verify.log" 2>&1 || fail "systemd-analyze verify: $(cat "$TMP/verify.log")"
grep -v "^$" "$TMP/verify.log" && fail "systemd-analyze verify printed warnings" || true
unit="$root/lib/systemd/system/robot-agent.service"
for line in "Restart=on-failure" "RestartPreventExitStatus=78" "WantedBy=multi-user.target" \
  "ExecStart=/usr/bin/robot-agent service --settings /etc/robot-agent/agent.toml"; do
  grep -qxF "$line" "$unit" || fail "the unit lacks $line"
done
echo "$NAME: systemd-analyze verify: the unit is clean"

# The installed settings, as shipped, stop the service with status 78 (no restart loop).
runner_for "$root/usr/bin/robot-agent"
set +e
"${RUNNER[@]}" "$root/usr/bin/robot-agent" service --settings "$root/etc/robot-agent/agent.toml" \
  > "$TMP/service.log" 2>&1
status=$?
set -e
[ "$status" = 78 ] || fail "the shipped settings exited $status, not 78"
grep -q "robot_id is empty" "$TMP/service.log" || fail "no word of robot_id: $(cat "$TMP/service.log")"
sed -e 's/^robot_id = ""/robot_id = "miro1"/' -e 's|^connect = \[\]|connect = ["tcp/127.0.0.1:7447"]|' \
  "$root/etc/robot-agent/agent.toml" > "$TMP/agent.toml"
"${RUNNER[@]}" "$root/usr/bin/robot-agent" service --settings "$TMP/agent.toml" --check > "$TMP/check.log" 2>&1 \
  || fail "completed settings refused: $(cat "$TMP/check.log")"
grep -q -- "--robot-id miro1 --source ros1 --connect tcp/127.0.0.1:7447" "$TMP/check.log" \
  || fail "the settings' run command: $(cat "$TMP/check.log")"
echo "$NAME: passed"
