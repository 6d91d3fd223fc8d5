#!/usr/bin/env bash
# Pareto plot of `pliant tradeoff` output: surface-position error and instrument-force error against
# cost (ms of wall time per scene step), every setting, the Pareto front, the scene default.
# Usage: plot_tradeoff.sh TRADEOFF_CSV OUT_PNG [TITLE]
set -euo pipefail
csv=${1:?usage: plot_tradeoff.sh TRADEOFF_CSV OUT_PNG [TITLE]}
png=${2:?usage: plot_tradeoff.sh TRADEOFF_CSV OUT_PNG [TITLE]}
title=${3:-scene}
command -v gnuplot >/dev/null || { echo "plot_tradeoff.sh: gnuplot not found" >&2; exit 1; }
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
# Columns: 10 surface_rms_error_mm, 11 force_rms_error_N, 17 ms_per_scene_step, 18/19 Pareto flags,
# 20 is_default, 6 failed. Zero errors (the reference itself) cannot sit on a log axis: left out.
# Column 24 compared_with: "settings" rows (binary search, CG, dt) against the reference run,
# "resolution" rows (22 resolution_factor) against the finest-mesh reference; older CSVs have no
# column 24 and are all settings rows.
awk -F, 'NR > 1 && $24 != "resolution" && $6 == 0 && $10 > 0' "$csv" > "$tmp/all_surface.csv"
awk -F, 'NR > 1 && $24 != "resolution" && $6 == 0 && $11 > 0' "$csv" > "$tmp/all_force.csv"
awk -F, 'NR > 1 && $24 != "resolution" && $18 == 1 && $10 > 0' "$csv" | sort -t, -k17,17g > "$tmp/front_surface.csv"
awk -F, 'NR > 1 && $24 != "resolution" && $19 == 1 && $11 > 0' "$csv" | sort -t, -k17,17g > "$tmp/front_force.csv"
awk -F, 'NR > 1 && $20 == 1' "$csv" > "$tmp/default.csv"
awk -F, 'NR > 1 && $24 == "resolution" && $6 == 0' "$csv" | sort -t, -k22,22g > "$tmp/resolution.csv"
# One panel per error; a panel with no non-zero error says so instead of plotting nothing.
panel() {  # column, ylabel, title, all, front
  local col=$1 ylabel=$2 ptitle=$3 all=$4 front=$5
  echo "set title \"$ptitle\""
  echo "set ylabel \"$ylabel\""
  if [[ -s $all ]]; then
    echo "set logscale y"
    echo "plot \"$all\" using 17:$col with points pt 7 ps 0.6 lc rgb \"#999999\" title \"all settings\", \\"
    echo "     \"$front\" using 17:$col with linespoints pt 7 lw 2 lc rgb \"#d62728\" title \"Pareto front\", \\"
    if [[ -s $tmp/resolution.csv ]]; then
      echo "     \"$tmp/default.csv\" using 17:(\$$col > 0 ? \$$col : 1/0) with points pt 5 ps 1.6 lc rgb \"#1f77b4\" title \"scene default\", \\"
      echo "     \"$tmp/resolution.csv\" using 17:(\$$col > 0 ? \$$col : 1/0) with linespoints pt 9 ps 1.4 lw 2 lc rgb \"#2ca02c\" title \"mesh resolution factor (vs finest mesh)\", \\"
      echo "     \"$tmp/resolution.csv\" using 17:(\$$col > 0 ? \$$col : 1/0):(sprintf(\"x%g\", \$22)) with labels offset 1.5,0.8 notitle"
    else
      echo "     \"$tmp/default.csv\" using 17:(\$$col > 0 ? \$$col : 1/0) with points pt 5 ps 1.6 lc rgb \"#1f77b4\" title \"scene default\""
    fi
  else
    echo "unset logscale y"
    echo "set label 1 \"no non-zero error: no instrument, or every setting equals the reference\" at graph 0.5, graph 0.5 center"
    echo "plot \"$tmp/default.csv\" using 17:$col with points pt 5 ps 1.6 lc rgb \"#1f77b4\" title \"scene default\""
    echo "unset label 1"
  fi
}
{
  echo "set terminal pngcairo size 1200,520 font \",10\" noenhanced"
  echo "set output \"$png\""
  echo "set datafile separator \",\""
  echo "set multiplot layout 1,2 title \"Speed-accuracy trade: $title (reference: most iterations, smallest dt and held final gate)\""
  echo "set grid"
  echo "set key top right"
  echo "set xlabel \"wall time per scene step (ms, median)\""
  panel 10 "surface vertex RMS error at the end (mm)" "Contact-surface position error" \
    "$tmp/all_surface.csv" "$tmp/front_surface.csv"
  panel 11 "instrument force RMS error over time (N)" "Instrument force error" \
    "$tmp/all_force.csv" "$tmp/front_force.csv"
  echo "unset multiplot"
} > "$tmp/plot.gp"
gnuplot "$tmp/plot.gp"
