#!/usr/bin/env bash
# Makes docs/wireshark.png: Wireshark (Debian's wireshark-qt, on a virtual X display) with
# drivetap's plugin installed in a throw-away HOME, showing a generated bus (docs/formats.md
# "drivetap's Wireshark plugin"): a display filter on drivetap's fields, a Danfoss FC packet's
# tree and its drive values. Needs wireshark-qt, xvfb, xdotool and imagemagick.
#
#   scripts/wireshark_screenshot.sh [BUILD_DIR] [OUT.png]    default: build docs/wireshark.png
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
drivetap=$(cd "${1:-$root/build}" && pwd)/drivetap
out=${2:-$root/docs/wireshark.png}
die() { echo "wireshark_screenshot.sh: $*" >&2; exit 2; }
[ -x "$drivetap" ] || die "$drivetap: no drivetap there (first argument: the build directory)"
for tool in wireshark Xvfb xdotool import; do
  command -v "$tool" > /dev/null || die "$tool missing (apt-get install wireshark-qt xvfb xdotool imagemagick)"
done
work=$(mktemp -d)
display=":$((90 + RANDOM % 100))"
cleanup() {
  [ -n "${ws_pid:-}" ] && kill "$ws_pid" 2> /dev/null
  [ -n "${x_pid:-}" ] && kill "$x_pid" 2> /dev/null
  rm -rf "$work"
}
trap cleanup EXIT

export HOME=$work/home XDG_RUNTIME_DIR=$work DISPLAY=$display
unset XDG_CONFIG_HOME
mkdir -p "$HOME/.config/wireshark"
"$drivetap" wireshark --install > /dev/null
"$drivetap" generate --frames 3000 --seed 5 -o "$work/bus.log" > /dev/null 2>&1
"$drivetap" read "$work/bus.log" -q -w "$work/bus.pcapng" > /dev/null 2>&1
# A layout that shows the packet list, the tree and little of the bytes.
cat > "$HOME/.config/wireshark/preferences" << 'EOF'
gui.column.format: "No.", "%m", "Time", "%t", "Protocol", "%p", "Length", "%L", "Info", "%i"
gui.layout_type: 1
gui.packet_list_show_minimap: FALSE
EOF
cat > "$HOME/.config/wireshark/recent" << 'EOF'
gui.geometry_main_upper_pane: 300
gui.geometry_main_lower_pane: 640
column.width: %m, 60, %t, 100, %p, 110, %L, 60, %i, 1050
EOF
printf 'privs.warn_if_elevated: FALSE\n' > "$HOME/.config/wireshark/recent_common"

Xvfb "$display" -screen 0 1400x900x24 > /dev/null 2>&1 &
x_pid=$!
sleep 2
# Packet 591: a Danfoss FC reply to a parameter read (PKE with its AK and PNU under it).
wireshark -r "$work/bus.pcapng" -Y 'danfoss_fc.addr == 6 || drivetap.checksum_bad' -g 591 \
  > "$work/wireshark.log" 2>&1 &
ws_pid=$!
for _ in $(seq 60); do
  window=$(xdotool search --name 'bus.pcapng' 2> /dev/null | head -1 || true)
  [ -n "$window" ] && break
  sleep 1
done
[ -n "${window:-}" ] || die "Wireshark did not open a window ($(tail -1 "$work/wireshark.log"))"
sleep 4
xdotool windowmove "$window" 0 0 windowsize "$window" 1400 900
sleep 2
# Expand the plugin's two subtrees (their rows in this layout): Danfoss FC, then the annotation.
xdotool mousemove 80 398 click 1 key shift+Right
sleep 1
xdotool mousemove 80 653 click 1 key shift+Right
sleep 1
import -window root -crop 1400x830+0+0 "$out"
echo "wrote $out"
