#!/usr/bin/env bash
# Fly `aquaspec view` in a window with xdotool and print its frame rates.
#
#   DISPLAY=:77 tools/view_fly.sh FRAMES [view options...]
#
# Needs an X server (e.g. `Xvfb :77 -screen 0 1920x1080x24 &`) and xdotool.
# Over and over until the view has drawn FRAMES frames: W held while the
# mouse drags right (2 s), D+Q (1.5 s), E+S (1.5 s), a drag back left (2 s).
# Prints the view's last lines: median frame rate, slowest second, passes.
set -euo pipefail
cd "$(dirname "$0")/.."
frames=$1; shift
export XDG_RUNTIME_DIR=${XDG_RUNTIME_DIR:-/tmp}
out=$(mktemp)
.venv/bin/aquaspec view --frames "$frames" "$@" >"$out" 2>/dev/null &
pid=$!
wid=""
for _ in $(seq 1 120); do
  wid=$(xdotool search --name "aquaspec view" 2>/dev/null | head -1 || true)
  [ -n "$wid" ] && break
  sleep 0.5
done
[ -n "$wid" ] || { echo "no window appeared" >&2; kill "$pid"; exit 1; }
sleep 2
eval "$(xdotool getwindowgeometry --shell "$wid")"
cx=$((X + WIDTH / 4)); cy=$((Y + HEIGHT / 2))
while kill -0 "$pid" 2>/dev/null; do
  xdotool keydown w mousemove "$cx" "$cy" mousedown 1
  for _ in $(seq 1 20); do xdotool mousemove_relative -- 6 1; sleep 0.1; done
  xdotool mouseup 1 keyup w
  kill -0 "$pid" 2>/dev/null || break
  xdotool keydown d keydown q; sleep 1.5; xdotool keyup d keyup q
  xdotool keydown e keydown s; sleep 1.5; xdotool keyup e keyup s
  xdotool mousemove "$cx" "$cy" mousedown 1
  for _ in $(seq 1 20); do xdotool mousemove_relative -- -6 -1; sleep 0.1; done
  xdotool mouseup 1
done 2>/dev/null
wait "$pid" || true
tail -3 "$out"
rm -f "$out"
