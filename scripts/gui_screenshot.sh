#!/usr/bin/env bash
# Makes docs/georegistered_model.png, the README's picture of a georegistered
# model in COLMAP 3.8's GUI (issue 12):
#  1. a synthetic aerial survey (make_synthetic_scene --layout grid) whose
#     database holds SIMULATED GPS priors (latitude, longitude, altitude, as
#     COLMAP's feature_extractor stores EXIF GPS): 1 m noise, 10% displaced;
#  2. `colmap global_mapper` with --GlobalMapper.use_position_priors 1
#     --GlobalMapper.prior_is_gps 1: the model comes out in east-north-up
#     metres (OUT/0/georegistration.txt says so);
#  3. `colmap gui --import_path OUT/0 ...` under Xvfb with Mesa's software
#     OpenGL; xdotool closes the Log dock and turns, moves and zooms the view
#     as one would with the mouse (COLMAP 3.8's viewer opens looking at the
#     origin from below, for models whose y axis points down); Xvfb keeps
#     its screen as an XWD file (-fbdir), which a few lines of Python
#     (standard library only) crop to the COLMAP window and write as PNG.
#
# Usage (from the repository root, after the build):
#   scripts/gui_screenshot.sh [OUTPUT_PNG]      (default: docs/georegistered_model.png)
# Environment: BUILD_DIR (default build), NUM_IMAGES (default 100), SEED
# (default 0), WAIT_S (seconds between the GUI's start and the capture,
# default 20), KEEP_WORK=1 keeps the scratch folder.
# Needs: xvfb (xvfb-run), xauth, libgl1-mesa-dri, python3 (scripts/setup.sh
# installs them) and xdotool (apt-get install xdotool).
set -euo pipefail

repo_dir="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build_dir="${BUILD_DIR:-${repo_dir}/build}"
output_png="${1:-${repo_dir}/docs/georegistered_model.png}"
num_images="${NUM_IMAGES:-100}"
seed="${SEED:-0}"
wait_s="${WAIT_S:-20}"
colmap="${build_dir}/bin/colmap"
make_scene="${build_dir}/bin/make_synthetic_scene"

for tool in xvfb-run xauth xdotool python3; do
  if ! command -v "${tool}" >/dev/null; then
    echo "gui_screenshot.sh: ${tool} not found (apt-get install xvfb xauth xdotool python3)" >&2
    exit 1
  fi
done
for binary in "${colmap}" "${make_scene}"; do
  if [[ ! -x "${binary}" ]]; then
    echo "gui_screenshot.sh: ${binary} not built (ninja -C ${build_dir} colmap make_synthetic_scene)" >&2
    exit 1
  fi
done

work_dir="$(mktemp -d /tmp/gui_screenshot.XXXXXX)"
if [[ "${KEEP_WORK:-0}" != 1 ]]; then
  trap 'rm -rf "${work_dir}"' EXIT
fi
echo "Scratch folder: ${work_dir}"

# 1. The scene, with simulated GPS priors.
"${make_scene}" --output_path "${work_dir}/scene" --layout grid \
  --num_images "${num_images}" --verification ground_truth \
  --prior_position_noise_m 1 --prior_outlier_ratio 0.1 --prior_as_gps 1 \
  --random_seed "${seed}" >"${work_dir}/make_scene.log"

# 2. The global mapper in the priors' frame.
mkdir -p "${work_dir}/out" "${work_dir}/images"
"${colmap}" global_mapper --database_path "${work_dir}/scene/database.db" \
  --image_path "${work_dir}/images" --output_path "${work_dir}/out" \
  --GlobalMapper.use_position_priors 1 --GlobalMapper.prior_is_gps 1 \
  --GlobalMapper.prior_position_std_m 1 >"${work_dir}/mapper.log" 2>&1
echo "--- ${work_dir}/out/0/georegistration.txt"
cat "${work_dir}/out/0/georegistration.txt"

# 3. The GUI under Xvfb. Without a window manager COLMAP's main window opens
# at 1024x600 in the top-left corner; the view steps below are in its pixels.
export QT_QPA_PLATFORM=xcb LIBGL_ALWAYS_SOFTWARE=1
export COLMAP_BIN="${colmap}" WORK_DIR="${work_dir}" WAIT_S="${wait_s}"
xvfb-run -a -s "-screen 0 1600x1000x24 -fbdir ${work_dir}" bash -c '
  set -euo pipefail
  "${COLMAP_BIN}" gui --import_path "${WORK_DIR}/out/0" \
    --database_path "${WORK_DIR}/scene/database.db" \
    --image_path "${WORK_DIR}/images" >"${WORK_DIR}/gui.log" 2>&1 &
  gui_pid=$!
  sleep "${WAIT_S}"
  if ! kill -0 "${gui_pid}" 2>/dev/null; then
    echo "gui_screenshot.sh: colmap gui exited early:" >&2
    cat "${WORK_DIR}/gui.log" >&2
    exit 1
  fi
  eval "$(xdotool search --onlyvisible --name "^COLMAP" getwindowgeometry --shell)"
  echo "${WIDTH}x${HEIGHT}+${X}+${Y}" >"${WORK_DIR}/geometry.txt"
  if [[ "${WIDTH}x${HEIGHT}+${X}+${Y}" != "1024x600+0+0" ]]; then
    echo "gui_screenshot.sh: the COLMAP window is ${WIDTH}x${HEIGHT}+${X}+${Y}, the view steps expect 1024x600+0+0" >&2
    exit 1
  fi
  drag() {  # button x0 y0 x1 y1: a mouse drag in 20 steps
    xdotool mousemove "$2" "$3" mousedown "$1"
    for k in $(seq 1 20); do
      xdotool mousemove $(($2 + ($4 - $2) * k / 20)) $(($3 + ($5 - $3) * k / 20))
      sleep 0.03
    done
    xdotool mouseup "$1"
  }
  wheel() {  # button clicks [modifier]: 4 zooms in, 5 out (ctrl: point size, alt: camera size)
    xdotool mousemove 512 312
    [[ -z "${3:-}" ]] || xdotool keydown "$3"
    xdotool click --repeat "$2" --delay 200 "$1"
    [[ -z "${3:-}" ]] || xdotool keyup "$3"
  }
  xdotool mousemove 1016 64 click 1  # close the Log dock: the view is 1024 wide
  sleep 2
  # The view centre is (512, 312). A drag through it turns the view about
  # the screen axis across the drag (arcball) by 2 asin(d / half the view):
  # 455 px right turns 125 degrees about the vertical, so that z (up) points
  # up the screen and towards the viewer; 56 px up then lowers the view to
  # 35 degrees above the horizon. Right drags move the model, the wheel
  # zooms.
  drag 1 512 312 967 312
  wheel 5 2
  drag 3 196 380 512 312
  wheel 5 4
  drag 3 426 380 512 300
  drag 1 512 312 512 256
  wheel 4 20 alt
  wheel 4 6 ctrl
  xdotool mousemove 1599 999  # the cursor out of the window
  sleep 3
  cp "${WORK_DIR}/Xvfb_screen0" "${WORK_DIR}/screen.xwd"
  kill "${gui_pid}"
  wait "${gui_pid}" 2>/dev/null || true
'

mkdir -p "$(dirname "${output_png}")"
python3 - "${work_dir}/screen.xwd" "$(cat "${work_dir}/geometry.txt")" \
  "${output_png}" <<'PYTHON'
"""XWD (32 bits per pixel, TrueColor) -> RGB PNG of the window WxH+X+Y."""
import re
import struct
import sys
import zlib

xwd_path, geometry, png_path = sys.argv[1:4]
with open(xwd_path, "rb") as f:
    data = f.read()
# XWDFileHeader: 25 big-endian CARD32.
header = struct.unpack(">25I", data[:100])
header_size, version, pixmap_format = header[0:3]
width, height = header[4:6]
byte_order, bits_per_pixel, bytes_per_line = header[7], header[11], header[12]
masks, num_colors = header[14:17], header[19]
if version != 7 or pixmap_format != 2 or bits_per_pixel != 32:
    sys.exit("unsupported xwd: version %d, format %d, %d bits per pixel"
             % (version, pixmap_format, bits_per_pixel))
pixels = data[header_size + 12 * num_colors:]
shifts = [(mask & -mask).bit_length() - 1 for mask in masks]
order = "<" if byte_order == 0 else ">"

w, h, x0, y0 = (int(v) for v in re.fullmatch(
    r"(\d+)x(\d+)\+(\d+)\+(\d+)", geometry).groups())
w, h = min(w, width - x0), min(h, height - y0)
raw = bytearray()
for y in range(y0, y0 + h):
    values = struct.unpack_from(order + "%dI" % w, pixels,
                                y * bytes_per_line + 4 * x0)
    row = bytearray(3 * w)
    for channel in range(3):
        mask, shift = masks[channel], shifts[channel]
        row[channel::3] = bytes((v & mask) >> shift for v in values)
    if y == y0 + h // 2 and not row.strip(b"\0"):
        sys.exit("the window is black: nothing was drawn")
    raw += b"\0" + row  # filter type 0 (none)


def chunk(kind, payload):
    return (struct.pack(">I", len(payload)) + kind + payload +
            struct.pack(">I", zlib.crc32(kind + payload) & 0xFFFFFFFF))


with open(png_path, "wb") as f:
    f.write(b"\x89PNG\r\n\x1a\n")
    f.write(chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0)))
    f.write(chunk(b"IDAT", zlib.compress(bytes(raw), 9)))
    f.write(chunk(b"IEND", b""))
print("Wrote %s (%dx%d)" % (png_path, w, h))
PYTHON
ls -l "${output_png}"
