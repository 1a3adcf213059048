#!/bin/sh
# The recorder's cost (docs/RECORDING.md, docs/BENCHMARKS.md): mocapd with
# two test cameras (the fault-injection driver, no faults: a moving
# pattern) at RECORD_SIZE and RECORD_FPS in RECORD_FORMAT, no tracker;
# RECORD_SECONDS of capture alone, then as long recording a take.  Prints
# the frames each camera delivered and the take kept or dropped, the
# recorder's disk rate, and mocapd's CPU with and without recording.
# Usage: tests/bench/record.sh BUILD_DIR   (from the repository root)
set -eu
build=${1:-build}
size=${RECORD_SIZE:-1280x1024}
fps=${RECORD_FPS:-60}
format=${RECORD_FORMAT:-yuyv}
secs=${RECORD_SECONDS:-5}
w=${size%x*}
h=${size#*x}
tmp=$(mktemp -d /tmp/mocap-bench-record-XXXXXX)
trap 'kill $pid 2>/dev/null; rm -rf "$tmp"' EXIT
cat >"$tmp/r.conf" <<CONF
[daemon]
plugin_dir = $PWD/$build/tests/faulty
[camera a]
driver = faulty
device = a
format = $format
width = $w
height = $h
fps = $fps
[camera b]
driver = faulty
device = b
format = $format
width = $w
height = $h
fps = $fps
[tracker]
enabled = false
[socket]
path = $tmp/s.sock
[record]
directory = ${RECORD_DIR:-$tmp/takes}
sync_ms = ${RECORD_SYNC_MS:-100}
CONF
"$build/bin/mocapd" -c "$tmp/r.conf" >"$tmp/out.txt" 2>"$tmp/err.txt" &
pid=$!
for _ in $(seq 100); do [ -S "$tmp/s.sock" ] && break; sleep 0.1; done
ticks() { awk '{print $14 + $15}' "/proc/$pid/stat"; }
hz=$(getconf CLK_TCK)
sleep 1
t0=$(ticks); sleep "$secs"; t1=$(ticks)
"$build/bin/mocapctl" --socket "$tmp/s.sock" record start --name bench >/dev/null
t2=$(ticks); sleep "$secs"; t3=$(ticks)
"$build/bin/mocapctl" --socket "$tmp/s.sock" record stop
take=${RECORD_DIR:-$tmp/takes}/bench
cpu_idle=$(echo "$t0 $t1 $hz $secs" | awk '{printf "%.0f", 100 * ($2 - $1) / $3 / $4}')
cpu_rec=$(echo "$t2 $t3 $hz $secs" | awk '{printf "%.0f", 100 * ($2 - $1) / $3 / $4}')
bytes=$(du -sb "$take" | cut -f1)
echo "bench-record: $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //'), $(nproc) cores"
echo "bench-record: 2 cameras $size $format at $fps fps, sync_ms ${RECORD_SYNC_MS:-100}, $secs s recorded into $(df -P "$take" | tail -1 | awk '{print $1}')"
awk -v secs="$secs" -v fps="$fps" '
	/"name": "[ab]"/ { gsub(/[",]/, "", $2); name = $2 }
	/"frames":/ { gsub(",", "", $2); frames = $2 }
	/"dropped":/ { printf "bench-record: camera %s: %d frames kept of about %d delivered, %d dropped\n", name, frames, secs * fps, $2 }
' "$take/take.json"
echo "$bytes $secs" | awk '{printf "bench-record: %.1f MB/s written\n", $1 / $2 / 1e6}'
echo "bench-record: mocapd CPU: $cpu_idle % capturing, $cpu_rec % capturing and recording (100 % = one core)"
