#!/usr/bin/env bash
# Builds and runs the rough-interface example (3000 asperities, F_N = 5 kN, three fretting cycles)
# and plots its hysteresis loop and energy per cycle to build/release/examples/rough_interface/.
#   bash examples/rough_interface/run.sh [extra flags of mdr_rough_interface]
set -euo pipefail
repo=$(cd "$(dirname "$0")/../.." && pwd)
cd "$repo"
bash deploy/build.sh release --target mdr_rough_interface
out=build/release/examples/rough_interface
build/release/examples/rough_interface/mdr_rough_interface --out "$out" "$@"
gnuplot <<PLOT
set terminal pngcairo size 1000,420 noenhanced
set output '$out/rough_interface.png'
set datafile separator ','
set multiplot layout 1,2
stats '$out/rough_interface_energy.csv' every ::1 using 1 nooutput
cycles = int(STATS_max) + 1
set title 'tangential force against displacement'
set xlabel 'u_x (um)'; set ylabel 'F_x (N)'; set key left top
plot for [c=0:cycles-1] '$out/rough_interface_loop.csv' every ::1 \
  using (\$1==c ? \$2*1e6 : NaN):3 with lines title sprintf('cycle %d', c)
set title 'energy dissipated per cycle (bars) and loop area (points)'
set xlabel 'cycle'; set ylabel 'uJ'; set yrange [0:*]; set xtics 1
set style fill solid 0.5; set boxwidth 0.6; set key left top
plot '$out/rough_interface_energy.csv' every ::1 using 1:(\$2*1e6) with boxes title 'dissipated', \
  '' every ::1 using 1:(\$3*1e6) with points pt 7 title 'loop area'
unset multiplot
PLOT
echo "wrote $out/rough_interface.png, rough_interface_loop.csv, rough_interface_energy.csv"
