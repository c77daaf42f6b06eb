#!/usr/bin/env bash
# Faults end to end: the user's files survive every failure, and nothing
# named *.tmp.* is left after any of them.
# - outputs that are inputs (by name, through a symbolic link, a hard link,
#   a relative path), two outputs that are one file, outputs that are a
#   link, a device, a FIFO, a directory or read-only: refused before any
#   work, exit 2, one line, nothing changed;
# - a full disk for every format (OBJ, PLY, EXR, PNG, and the study's
#   files): a small full tmpfs in a private mount namespace (unshare), or
#   where that is not allowed a file size limit (the same failed write(2),
#   EFBIG instead of ENOSPC); exit 1 (the system failed, not the user's
#   input), one line naming the file and the errno, the previous outputs as
#   they were;
# - SIGINT and SIGTERM while the outputs are being written: exit 130 / 143,
#   no temporary left, the previous file as it was; SIGKILL: the temporary
#   stays, and the next run writing that output removes it (with a warning).
# usage: [FAULTS_MODE=tmpfs|mount|fsize] test_faults.sh CHISEL MODELS_DIR TESTS_DIR TMP_DIR
set -u
chisel=$1 models=$2 tests=$3 tmp=$4
rm -rf "$tmp"
mkdir -p "$tmp"
cd "$tmp" || exit 1
failures=0 checks=0
fail() { echo "FAIL: $*" >&2; failures=$((failures + 1)); }
# expect STATUS CMD...: runs CMD, checks its exit status; stderr in err.txt
expect() {
  local want=$1
  shift
  checks=$((checks + 1))
  "$@" >out.txt 2>err.txt
  local got=$?
  if [ "$got" != "$want" ]; then
    fail "exit $got (want $want): $*"
    sed 's/^/    /' err.txt >&2
    return 1
  fi
}
one_line_with() {
  checks=$((checks + 1))
  local n
  n=$(wc -l <err.txt)
  [ "$n" = 1 ] || { fail "$n stderr lines (want 1) for '$1':"; sed 's/^/    /' err.txt >&2; return; }
  grep -qF -- "$1" err.txt || fail "stderr lacks '$1': $(cat err.txt)"
}
same() { # same FILE COPY: FILE is unchanged
  checks=$((checks + 1))
  cmp -s "$1" "$2" || fail "$1 changed"
}
no_temp() { # no_temp DIR...
  checks=$((checks + 1))
  local left
  left=$(find "$@" -name '*.tmp.*' 2>/dev/null)
  [ -z "$left" ] || fail "temporaries left: $left"
}

cp "$models/plane.obj" in.obj
cp "$models/curves/glyphs.svg" c.svg
cp "$models/curves/steps_simple.svg" steps.svg
cp "$models/curves/relief.svg" relief.svg
cp in.obj in.orig
cp c.svg c.orig
# (after a section's checks: its failures do not cascade into the next)
restore() { cp in.orig in.obj && cp c.orig c.svg; }
small=(--target-tris 4000 --no-snap --res 64)

# ---- outputs that are inputs, or each other, or not plain files ----
expect 2 "$chisel" displace in.obj c.svg -o in.obj "${small[@]}" && one_line_with "in.obj: is the input in.obj"
expect 2 "$chisel" displace in.obj c.svg -o c.svg "${small[@]}" && one_line_with "is the input c.svg"
expect 2 "$chisel" displace in.obj c.svg -o out.obj --ply c.svg "${small[@]}" && one_line_with "is the input c.svg"
expect 2 "$chisel" displace in.obj c.svg -o ./../"$(basename "$tmp")"/in.obj "${small[@]}" && one_line_with "is the input"
ln -s in.obj link.obj
expect 2 "$chisel" displace in.obj c.svg -o link.obj "${small[@]}" && one_line_with "link.obj: is a symbolic link"
expect 2 "$chisel" displace link.obj c.svg -o in.obj "${small[@]}" && one_line_with "is the input link.obj"
ln in.obj hard.obj
expect 2 "$chisel" displace in.obj c.svg -o hard.obj "${small[@]}" && one_line_with "hard.obj: is the input in.obj"
expect 2 "$chisel" displace in.obj c.svg -o same.obj --ply ./same.obj "${small[@]}" && one_line_with "name the same file"
expect 2 "$chisel" displace in.obj c.svg -o same.obj --exr sub/../same.obj "${small[@]}" && one_line_with "cannot write into"
mkdir sub
expect 2 "$chisel" displace in.obj c.svg -o same.obj --exr sub/../same.obj "${small[@]}" && one_line_with "name the same file"
expect 2 "$chisel" displace in.obj c.svg -o sub "${small[@]}" && one_line_with "sub: is a directory"
expect 2 "$chisel" displace in.obj c.svg -o sub/ "${small[@]}" && one_line_with "names a directory"
expect 2 "$chisel" displace in.obj c.svg -o /dev/null "${small[@]}" && one_line_with "/dev/null: is a device"
checks=$((checks + 1))
[ -c /dev/null ] || fail "/dev/null is no longer a device"
mkfifo fifo.obj
expect 2 timeout 20 "$chisel" displace in.obj c.svg -o fifo.obj "${small[@]}" && one_line_with "fifo.obj: is a device, FIFO"
echo "read only" >ro.obj
chmod 444 ro.obj
expect 2 "$chisel" displace in.obj c.svg -o ro.obj "${small[@]}" && one_line_with "ro.obj: exists and is read-only"
checks=$((checks + 1))
[ "$(cat ro.obj)" = "read only" ] || fail "ro.obj changed"
expect 2 "$chisel" sample c.svg --res 16 -o c.svg && one_line_with "is the input c.svg"
expect 2 "$chisel" dci steps.svg --res 16 -o d.exr --png d.exr && one_line_with "name the same file"
"$chisel" dci relief.svg --res 64 -o maps.exr 2>/dev/null
cp maps.exr maps.orig
expect 2 "$chisel" magnify maps.exr --rect 0,0,1,1 --out-res 16 -o m.png --exr maps.exr && one_line_with "is the input maps.exr"
same maps.exr maps.orig
# the study: a scene kept in its output folder under a name the study writes
mkdir st
cp in.obj st/plane.obj
cat >st/summary.json <<'EOF'
{"curves": "../c.svg", "views": [{"name": "top", "eye": [0.5, -0.3, 1.5], "target": [0.5, 0.5, 0], "width": 160, "height": 120}],
 "methods": [{"name": "snapped", "mesh": "plane.obj"}]}
EOF
cp st/summary.json st.orig
expect 2 "$chisel" study st/summary.json -o st && one_line_with "st/summary.json: is the input st/summary.json"
same st/summary.json st.orig
# UDIM: each tile's curve file is an input too (which ones is known only
# once the mesh is read: every existing tile file of CURVES counts)
mkdir udim
cp "$tests/data/mesh/udim_two_tiles.obj" udim/m.obj
cp "$models/curves/frame.svg" udim/c.1001.svg
cp "$models/curves/star.svg" udim/c_1002.svg
cp udim/c_1002.svg udim/tile.orig
ln udim/c_1002.svg udim/hard.svg
expect 2 "$chisel" displace udim/m.obj udim/c.svg -o udim/c_1002.svg "${small[@]}" &&
  one_line_with "udim/c_1002.svg: is the input udim/c_1002.svg (the curves of UDIM tile 1002)"
expect 2 "$chisel" displace udim/m.obj 'udim/c.<UDIM>.svg' -o udim/x.obj --ply ./udim/c.1001.svg "${small[@]}" &&
  one_line_with "(the curves of UDIM tile 1001)"
expect 2 "$chisel" displace udim/m.obj udim/c.svg -o udim/hard.svg "${small[@]}" &&
  one_line_with "hard.svg: is the input udim/c_1002.svg"
same udim/c_1002.svg udim/tile.orig
checks=$((checks + 1))
[ ! -e udim/x.obj ] || fail "udim/x.obj written"
same in.obj in.orig
same c.svg c.orig
no_temp .
restore

# ---- a full disk, every format ----
# full_run DIR CMD...: runs CMD with DIR a full file system; listing.txt
# gets what DIR held afterwards.
mode=${FAULTS_MODE:-} # (tmpfs, mount or fsize to choose; by default the first that works)
mkdir -p full
if [ -n "$mode" ]; then
  :
elif unshare -rm sh -c 'mount -t tmpfs -o size=64k tmpfs "$1"' sh full 2>/dev/null; then
  mode=tmpfs
elif [ "$(id -u)" = 0 ] && mount -t tmpfs -o size=64k tmpfs full 2>/dev/null && umount full; then
  mode=mount
else
  mode=fsize
fi
full_run() {
  local dir=$1
  shift
  case $mode in
  tmpfs)
    unshare -rm sh -c 'mount -t tmpfs -o size=64k tmpfs "$1" || exit 99; shift; "$@"; rc=$?; ls -A full >listing.txt; exit $rc' \
      sh "$dir" "$@" ;;
  mount)
    mount -t tmpfs -o size=64k tmpfs "$dir" || return 99
    "$@"
    local rc=$?
    ls -A full >listing.txt
    umount "$dir"
    return $rc ;;
  fsize) # 64 kB per file, SIGXFSZ ignored: the write fails with EFBIG
    (trap '' XFSZ; ulimit -f 64; "$@")
    local rc=$?
    ls -A full >listing.txt
    return $rc ;;
  esac
}
errno_text="No space left on device (ENOSPC)"
[ $mode = fsize ] && errno_text="File too large (EFBIG)"
echo "test_faults: full disk by $mode" >&2
echo "previous" >out.obj
cp out.obj out.orig
big=(--target-tris 20000 --no-snap --res 512)
for fmt in obj ply exr png; do
  case $fmt in
  obj) args=(-o full/x.obj) ;;
  ply) args=(-o out.obj --ply full/x.ply) ;;
  exr) args=(-o out.obj --exr full/x.exr) ;;
  png) args=(-o out.obj --png full/x.png) ;;
  esac
  # (a file size limit holds for every file: there only the OBJ can be the one that fails)
  [ $mode = fsize ] && [ $fmt != obj ] && continue
  expect 1 full_run full "$chisel" displace in.obj c.svg "${args[@]}" "${big[@]}" &&
    one_line_with "full/x.$fmt: cannot write: $errno_text"
  checks=$((checks + 1))
  [ ! -s listing.txt ] || fail "$fmt: left in the full folder: $(cat listing.txt)"
  same out.obj out.orig
done
# standard output into a full file system (the partial file is the shell's)
expect 1 full_run full sh -c '"$1" displace in.obj c.svg -o - --target-tris 20000 --no-snap >full/s.obj' sh "$chisel" &&
  one_line_with "(standard output): cannot write: $errno_text"
rm -f full/s.obj
expect 1 full_run full "$chisel" sample c.svg --res 512 -o full/h.exr && one_line_with "full/h.exr: cannot write: $errno_text"
expect 1 full_run full "$chisel" dci steps.svg --res 128 -o full/d.exr && one_line_with "full/d.exr: cannot write"
if [ $mode = fsize ]; then
  expect 1 full_run full "$chisel" magnify maps.exr --rect 0,0,1,1 --out-res 1024 -o full/m.png &&
    one_line_with "full/m.png: cannot write: $errno_text"
else
  expect 1 full_run full "$chisel" magnify maps.exr --rect 0,0,1,1 --out-res 1024 -o m.png --exr full/m.exr &&
    one_line_with "full/m.exr: cannot write: $errno_text"
  checks=$((checks + 1))
  [ ! -e m.png ] || fail "magnify: m.png written though the run failed"
fi
sed 's#"\.\./c\.svg"#"c.svg"#; s#"plane.obj"#"in.obj"#' st.orig >scene.json
expect 1 full_run full "$chisel" study scene.json -o full/study && one_line_with "cannot write"
checks=$((checks + 1))
[ ! -s listing.txt ] || fail "study: left in the full folder: $(cat listing.txt)"
same in.obj in.orig
same c.svg c.orig
no_temp .
restore

# ---- signals while writing ----
# The outputs are staged until all are written, so the temporaries live
# through the whole write phase (about a second here): wait for the first,
# then signal. Job control, so the background job does not ignore SIGINT.
set -m
interrupt() { # interrupt SIGNAL WANT
  echo "previous" >o/out.obj
  "$chisel" displace in.obj c.svg -o o/out.obj --ply o/out.ply --exr o/out.exr --png o/out.png \
    --target-tris 200000 --no-snap --res 1024 2>err.txt &
  local pid=$! seen=0
  for _ in $(seq 1 3000); do
    if ls o | grep -q '\.tmp\.'; then seen=1; break; fi
    sleep 0.01
  done
  kill -"$1" $pid 2>/dev/null
  wait $pid
  local rc=$?
  checks=$((checks + 1))
  [ $seen = 1 ] || fail "$1: no temporary seen while writing"
  checks=$((checks + 1))
  [ $rc = "$2" ] || fail "$1: exit $rc (want $2): $(cat err.txt)"
}
mkdir -p o
interrupt INT 130
grep -q "interrupted by SIGINT" err.txt || fail "SIGINT: no line saying so: $(cat err.txt)"
no_temp o
checks=$((checks + 1))
[ "$(cat o/out.obj)" = previous ] && [ ! -e o/out.ply ] || fail "SIGINT: outputs changed"
interrupt TERM 143
no_temp o
checks=$((checks + 1))
[ "$(cat o/out.obj)" = previous ] || fail "SIGTERM: out.obj changed"
interrupt KILL 137
checks=$((checks + 1))
ls o | grep -q '^out\.obj\.tmp\.chisel-[0-9]*-......$' || fail "SIGKILL: no temporary left to clean (the test saw: $(ls o))"
expect 0 "$chisel" displace -q in.obj c.svg -o o/out.obj "${small[@]}" && one_line_with "left by an interrupted run"
checks=$((checks + 1))
[ -z "$(ls o | grep '^out\.obj\.tmp\.')" ] || fail "the stale temporary of out.obj was not removed: $(ls o)"
set +m
same in.obj in.orig
same c.svg c.orig
restore

# ---- progress: a line on a terminal once a run has taken 2 s, none otherwise ----
if command -v script >/dev/null; then
  start=$(date +%s%N)
  script -qec "'$chisel' displace in.obj c.svg -o tty.obj --target-tris 130000" /dev/null >tty.txt 2>&1
  took=$(( ($(date +%s%N) - start) / 1000000 ))
  checks=$((checks + 1))
  if [ $took -ge 3000 ]; then # (a faster run may end before the line shows)
    tr '\r' '\n' <tty.txt | grep -q "^chisel displace: .*(2 s)" || fail "no progress line on a terminal in $took ms"
  fi
  tr '\r' '\n' <tty.txt | grep -q "warning\|error" && fail "the terminal run complained: $(cat tty.txt)"
fi
expect 0 "$chisel" displace in.obj c.svg -o notty.obj --target-tris 130000
checks=$((checks + 1))
grep -q "$(printf '\r')" err.txt && fail "progress drawn though stderr is not a terminal"

echo "$checks checks, $failures failures" >&2
[ "$failures" = 0 ]
