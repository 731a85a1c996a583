#!/usr/bin/env bash
# Screenshots of the rerun viewer showing a recording, taken headless, for the README (docs/).
#   scripts/screenshot.sh out/trigait.rrd docs/
# writes docs/viewer.png (the default layout once playback has reached the end of the
# recording), docs/viewer-flexion.png (its knee and hip flexion charts at full size) and
# docs/viewer-sync.png (the clock sync tab). It fails when the viewer warns that a keypoint
# connection of the annotation context could not be resolved.
#
# Needs an X server without a screen and software Vulkan (Debian: `apt-get install xvfb
# mesa-vulkan-drivers imagemagick xdotool`; GL software rendering does not start the viewer,
# and without the Composite extension the window stays black). Installs nothing itself; CI does
# not run it. The viewer is `.venv/bin/rerun` (scripts/venv.sh).
set -euo pipefail
cd "$(dirname "$0")/.."
rrd="${1:?usage: scripts/screenshot.sh FILE.rrd OUT_DIR}"
dir="${2:?usage: scripts/screenshot.sh FILE.rrd OUT_DIR}"
mkdir -p "$dir"
display="${SCREENSHOT_DISPLAY:-:97}"
wait_secs="${SCREENSHOT_WAIT_SECS:-100}"
for tool in Xvfb import convert xdotool; do
  command -v "$tool" >/dev/null || { echo "screenshot.sh: $tool is missing (see the comment at the top)" >&2; exit 1; }
done

Xvfb "$display" -screen 0 1920x1080x24 -extension Composite >/dev/null 2>&1 &
xvfb=$!
viewer=""
cleanup() {
  # .venv/bin/rerun is a Python launcher: end the viewer binary it started, then the launcher.
  [ -n "$viewer" ] && { pkill -P "$viewer" 2>/dev/null; kill "$viewer" 2>/dev/null; } || true
  kill "$xvfb" 2>/dev/null || true
}
trap cleanup EXIT
sleep 2
log="$(mktemp)"
DISPLAY="$display" WGPU_BACKEND=vulkan .venv/bin/rerun --new "$rrd" >"$log" 2>&1 &
viewer=$!
# The window, full screen, once it exists.
for _ in $(seq 30); do
  win="$(DISPLAY="$display" xdotool search --name rerun 2>/dev/null | head -1 || true)"
  [ -n "$win" ] && break
  sleep 1
done
[ -n "$win" ] || { echo "screenshot.sh: the viewer opened no window; its log:" >&2; cat "$log" >&2; exit 1; }
DISPLAY="$display" xdotool windowmove "$win" 0 0 windowsize "$win" 1920 1080
# Playback runs from the start, slower than real time under software rendering (a 15 s run
# takes about a minute): wait past the end, with the pointer off the views.
DISPLAY="$display" xdotool mousemove 1919 1079
sleep "$wait_secs"
shot="$(mktemp --suffix=.png)"
DISPLAY="$display" import -window root "$shot"
convert "$shot" -resize 1600x900 "PNG8:$dir/viewer.png"
# The flexion charts: the middle of the right column (the layout's shares put them there).
convert "$shot" -crop 900x250+1020+335 +repage "PNG8:$dir/viewer-flexion.png"
# The second tab of the lower right tab bar (clock sync).
DISPLAY="$display" xdotool mousemove "${TAB_X:-1259}" "${TAB_Y:-582}" click 1 mousemove 1919 1079
sleep 5
DISPLAY="$display" import -window root "$shot"
convert "$shot" -resize 1600x900 "PNG8:$dir/viewer-sync.png"
rm -f "$shot"
for f in viewer viewer-flexion viewer-sync; do
  echo "wrote $dir/$f.png ($(du -k "$dir/$f.png" | cut -f1) kB)"
done
if grep -q "could not be resolved" "$log"; then
  echo "screenshot.sh: the viewer warned about the annotation context:" >&2
  grep "could not be resolved" "$log" >&2
  exit 1
fi
