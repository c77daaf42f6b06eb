#!/usr/bin/env bash
# Pathological curve sets (bench/pathological.py) through `chisel displace`
# over the plane at 130k triangles: many small closed step loops, many v
# grooves through one point, one very long path; each at four sizes, so
# the table shows how time grows with the curves (the exponent of the CPU
# time between consecutive sizes: 1 is linear; CPU time, as the machine
# may be shared). Also the reading of a 1M-segment SVG
# (18 MB). Prints wall and CPU time, peak memory, the output's triangles.
#
# usage: bench/pathological.sh [BUILD_DIR] [TIMEOUT_S] [SERIES...]
#   BUILD_DIR defaults to build; TIMEOUT_S (default 600) stops a run (shown
#   as "> T s"); SERIES: any of loops crossing path read (default: all).
#   QUICK=1 runs only the largest size of each series; LAST=N the N largest
#   (LAST=2: the largest size and the exponent from the size below);
#   SIZES="1000 3000" replaces the sizes of every series given.
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build}
limit=${2:-600}
shift 2 2>/dev/null || shift $#
series=("$@")
[ ${#series[@]} -gt 0 ] || series=(loops crossing path read)
dir=out/pathological
mkdir -p "$dir"
chisel=$build/chisel
[ -x "$chisel" ] || { echo "no $chisel (build first)" >&2; exit 1; }
sizes_of() {
  case $1 in
  loops) echo 1250 2500 5000 10000 ;;
  crossing) echo 250 500 1000 2000 ;;
  path) echo 62500 125000 250000 500000 ;;
  read) echo 1000000 ;;
  esac
}
kind_of() { case $1 in path) echo path ;; read) echo bigpath ;; *) echo "$1" ;; esac; }
echo "$("$chisel" --version) ($chisel), $(nproc) threads, timeout $limit s; exponent: of the CPU time between sizes"
printf "| %-9s | %8s | %9s | %9s | %8s | %9s | %8s | %s\n" series curves wall_s cpu_s peak_MB triangles exponent status
echo "|---|---|---|---|---|---|---|---|"
for s in "${series[@]}"; do
  sizes=($(sizes_of "$s"))
  [ -n "${SIZES:-}" ] && sizes=($SIZES)
  [ -n "${QUICK:-}" ] && sizes=("${sizes[-1]}")
  [ -n "${LAST:-}" ] && [ "$LAST" -lt ${#sizes[@]} ] && sizes=("${sizes[@]: -$LAST}")
  prev_n="" prev_t=""
  for n in "${sizes[@]}"; do
    svg=$dir/$(kind_of "$s")_$n.svg
    [ -s "$svg" ] || python3 bench/pathological.py "$(kind_of "$s")" "$n" "$svg"
    if [ "$s" = read ]; then
      cmd=("$chisel" info "$svg")
    else
      cmd=("$chisel" displace models/plane.obj "$svg" -o "$dir/out.obj" --target-tris 130000 --stats)
    fi
    set +e
    /usr/bin/time -f "%e %U %S %M" -o "$dir/time.txt" timeout "$limit" "${cmd[@]}" >"$dir/stdout.txt" 2>"$dir/stderr.txt"
    rc=$?
    set -e
    # (time's last line: a failed run's has "Command exited with ..." before it)
    read -r wall user sys rss < <(tail -n 1 "$dir/time.txt") || true
    tris=$(grep -o 'displace [0-9]* triangles' "$dir/stderr.txt" | grep -o '[0-9]*' || true)
    [ "$s" = read ] && tris=$(sed -n 's/^ *segments *\([0-9]*\).*/\1 segs/p' "$dir/stdout.txt")
    status=ok
    if [ $rc = 124 ]; then
      status="timeout"
      wall="> $limit"
    elif [ $rc != 0 ]; then
      status="exit $rc: $(grep -v warning "$dir/stderr.txt" | tail -1 | cut -c1-60)"
    fi
    cpu=$(python3 -c "print('%.1f' % ($user + $sys))" 2>/dev/null || echo "?")
    exponent=""
    if [ $rc = 0 ] && [ -n "$prev_t" ]; then
      exponent=$(python3 -c "import math; print('%.2f' % (math.log($cpu / $prev_t) / math.log($n / $prev_n)))" 2>/dev/null || true)
    fi
    printf "| %-9s | %8s | %9s | %9s | %8s | %9s | %8s | %s\n" "$s" "$n" "$wall" "$cpu" "$((rss / 1024))" \
      "${tris:-}" "$exponent" "$status"
    if [ $rc = 0 ]; then prev_n=$n prev_t=$cpu; else prev_t=""; fi
  done
done
rm -f "$dir/out.obj"
