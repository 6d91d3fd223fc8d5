#!/usr/bin/env bash
# Redraws DIR/energy.png and DIR/penetration.png of a `pliant experiment` run from its
# DIR/{surface,penalty}/steps.csv with the DIR/plots.gp that the command wrote (gnuplot, pngcairo).
set -euo pipefail
dir=${1:?usage: scripts/plot_experiment.sh DIR (the --out folder of pliant experiment)}
cd "$dir"
gnuplot plots.gp
echo "wrote $dir/energy.png $dir/penetration.png"
