#!/bin/sh
# Regenerates the GTKWave screenshots the README and docs show, from dumps written by the
# current build, each opened with the save file written beside it:
#   docs/waves-spill.png  a real-scene dump (clutter, RB_2+SH_2+SK+RA), opening on its first
#                         RB -> SH spill
#   waves/screenshot.png  the sms_window stack-unit example (cargo run -p tb --example waves)
# Needs GTKWave (gtkwave), Xvfb (xvfb-run) and ImageMagick (import): Debian packages gtkwave,
# xvfb and imagemagick.
# Usage: scripts/waves-screenshot.sh
set -eu
cd "$(dirname "$0")/.."
for tool in gtkwave xvfb-run import; do
    command -v "$tool" >/dev/null || { echo "$tool is missing: apt-get install gtkwave xvfb imagemagick" >&2; exit 1; }
done
root=$(pwd)
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
cargo run -q --profile ci -p tb --bin sms -- run -q --scene clutter --res 16x16 --spp 1 --bounces 1 \
    -c RB_2+SH_2+SK+RA --vcd "$tmp/clutter_rb2.vcd" --vcd-to 3000 --vcd-sms 0 --vcd-warps 0 \
    --vcd-lanes 0,1,2,3 >/dev/null
cargo run -q --profile ci -p tb --example waves -- "$tmp" >/dev/null
# GTKWave opens at the save file's [size] (1400x900) in a screen of that size, run from the
# dump's folder so its title names the file alone; the capture waits for it to load and draw.
shot() {
    (cd "$tmp" && xvfb-run -a -s "-screen 0 1400x900x24" sh -c \
        "gtkwave '$1' '${1%.vcd}.gtkw' >/dev/null 2>&1 & sleep 8; import -window root '$root/$2'; kill \$!")
    echo "$2: $1 with ${1%.vcd}.gtkw"
}
shot clutter_rb2.vcd docs/waves-spill.png
shot sms_window.vcd waves/screenshot.png
