#!/bin/bash
# Plots convergence series from `volux bench --reference REF --json` output.
#   tools/plot/convergence.sh OUT.(svg|png) LABEL=series.jsonl [LABEL=series.jsonl ...]
# Two log-log panels: relMSE vs samples per pixel (with a 1/spp guide) and
# relMSE vs render time. Needs gnuplot (Debian: gnuplot-nox; installed if
# missing and we are root).
set -euo pipefail
out=${1:?usage: convergence.sh OUT.svg LABEL=series.jsonl ...}
shift
(($# > 0)) || { echo "convergence.sh: give at least one LABEL=series.jsonl" >&2; exit 2; }
if ! command -v gnuplot >/dev/null; then
  if [[ $(id -u) == 0 ]]; then apt-get install -y -qq gnuplot-nox >/dev/null; else
    echo "convergence.sh: gnuplot is missing (apt-get install gnuplot-nox)" >&2; exit 1; fi
fi
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT
plots_spp=() plots_ms=() i=0
for arg in "$@"; do
  label=${arg%%=*} file=${arg#*=}
  [[ -r $file ]] || { echo "convergence.sh: cannot read $file" >&2; exit 2; }
  # flat JSON lines: pull spp, ms and value out of the convergence rows
  awk '/"metric":"convergence.rel_mse"/ {
         match($0, /"value":[^,}]*/); v = substr($0, RSTART + 8, RLENGTH - 8)
         match($0, /"spp":[^,}]*/);   s = substr($0, RSTART + 6, RLENGTH - 6)
         match($0, /"ms":[^,}]*/);    m = substr($0, RSTART + 5, RLENGTH - 5)
         print s, m, v }' "$file" > "$tmp/$i.dat"
  [[ -s $tmp/$i.dat ]] || { echo "convergence.sh: no convergence rows in $file" >&2; exit 2; }
  plots_spp+=("'$tmp/$i.dat' using 1:3 with linespoints title '$label'")
  plots_ms+=("'$tmp/$i.dat' using 2:3 with linespoints title '$label'")
  i=$((i + 1))
done
first=$(head -n 1 "$tmp/0.dat" | awk '{print $3 * $1}')
join() { local IFS=','; echo "$*"; }
case $out in
  *.png) term='png size 960,400' ;;
  *) term='svg size 960,400 dynamic font "sans,11"' ;;
esac
gnuplot <<GP
set terminal $term
set output '$out'
set multiplot layout 1,2
set logscale xy
set grid
set key top right
set ylabel 'relMSE vs reference'
set xlabel 'samples per pixel'
plot $(join "${plots_spp[@]}"), $first/x with lines dashtype 2 lc 'gray' title '1/spp'
set xlabel 'render time (ms)'
plot $(join "${plots_ms[@]}")
unset multiplot
GP
echo "wrote $out"
