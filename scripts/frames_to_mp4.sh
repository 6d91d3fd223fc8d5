#!/usr/bin/env bash
# Assembles frame_NNNNNN.png files (written by `pliant run --frames` / FrameRecorder) into an MP4.
#   scripts/frames_to_mp4.sh FRAMES_DIR [OUTPUT.mp4] [FPS]
# FPS defaults to 30 (the scenes' default output.frame_rate). Frames are taken in name order with a
# glob, so gaps left by dropped frames (real-time runs) are simply skipped. H.264, yuv420p, even
# dimensions (players refuse odd ones).
set -euo pipefail

if [[ $# -lt 1 || $# -gt 3 || "$1" == "-h" || "$1" == "--help" ]]; then
  echo "usage: $0 FRAMES_DIR [OUTPUT.mp4] [FPS]" >&2
  exit 2
fi
frames_dir=$1
output=${2:-"$frames_dir/../frames.mp4"}
fps=${3:-30}

if ! command -v ffmpeg >/dev/null 2>&1; then
  echo "frames_to_mp4: ffmpeg is not installed; install it (e.g. 'apt-get install ffmpeg') or open" >&2
  echo "the PNG sequence in $frames_dir with any image viewer or ParaView." >&2
  exit 3
fi
if [[ ! -d "$frames_dir" ]]; then
  echo "frames_to_mp4: $frames_dir is not a directory" >&2
  exit 2
fi
shopt -s nullglob
frames=("$frames_dir"/frame_*.png)
if [[ ${#frames[@]} -eq 0 ]]; then
  echo "frames_to_mp4: no frame_*.png files in $frames_dir" >&2
  exit 2
fi
if ! [[ "$fps" =~ ^[0-9]+([.][0-9]+)?$ ]]; then
  echo "frames_to_mp4: FPS must be a positive number, got '$fps'" >&2
  exit 2
fi

ffmpeg -hide_banner -loglevel error -y -framerate "$fps" -pattern_type glob -i "$frames_dir/frame_*.png" \
  -vf "scale=trunc(iw/2)*2:trunc(ih/2)*2" -c:v libx264 -pix_fmt yuv420p -movflags +faststart "$output"
echo "frames_to_mp4: wrote $output (${#frames[@]} frames at $fps fps)"
