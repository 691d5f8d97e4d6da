#!/bin/sh
# Regenerates the GTKWave screenshots the README and docs show, from dumps written by the
# current build, each opened with the save file written beside it:
#   docs/waves-spill.png  README's waveform command (clutter, SMS, lanes 9-12 of warp slot 3),
#                         opening on its first RB -> SH spill; also rewrites waves/clutter_sms.gtkw
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
# README's command, word for word after `sms` (tb/tests/vcd_readme.rs runs it from README too).
cargo run -q --profile ci -p tb --bin sms -- run -c SMS --scene clutter --res 32x32 --spp 1 --bounces 1 \
    --vcd waves/clutter_sms.vcd --vcd-from 0 --vcd-to 3000 --vcd-sms 0 --vcd-warps 3 --vcd-lanes 9,10,11,12 \
    >/dev/null
cargo run -q --profile ci -p tb --example waves -- "$tmp" >/dev/null
# GTKWave opens at the save file's [size] (1400x900) in a screen of that size, run from the
# dump's folder so its title names the file alone; the capture waits for it to load and draw.
shot() {
    (cd "$1" && xvfb-run -a -s "-screen 0 1400x900x24" sh -c \
        "gtkwave '$2' '${2%.vcd}.gtkw' >/dev/null 2>&1 & sleep 8; import -window root '$root/$3'; kill \$!")
    echo "$3: $1/$2 with ${2%.vcd}.gtkw"
}
shot waves clutter_sms.vcd docs/waves-spill.png
shot "$tmp" sms_window.vcd waves/screenshot.png
