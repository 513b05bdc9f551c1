#!/usr/bin/env bash
# The ring detector against the seed's stages in OpenCV, on the same frames, one core each:
# per-frame time of both and the ratio, in one run. A benchmark, not part of .ci/run.
#
#   bench/compare.sh [FRAMES] [SCENE]     (defaults: 200 frames of the `dense` scene)
#
# Frames come from `gonio simulate frames --scene SCENE --raw` (seed 1), kept in
# target/compare-SCENE-FRAMES/. OpenCV runs bench/opencv_reference.py pinned to one core (taskset;
# one thread; its virtual environment is made on first use): the median of its per-frame CPU time,
# the stages alone on frames already in memory. gonio is timed twice on the same core:
#   - the same scope: `gonio detect --raw 1440x540 --timing`, the median of the detector's CPU
#     time per frame (crop + detect; reading the stream and writing JSON not counted);
#   - end to end: `gonio detect --raw 1440x540 --threads 1`, the process's CPU time (user + system:
#     start-up, reading standard input, detection, JSON output) divided by the frames.
# CPU times, so that other work on the machine does not count; run on a quiet machine for
# wall-clock figures.
set -euo pipefail
cd "$(dirname "$0")/.."
N=${1:-200}
SCENE=${2:-dense}
DIR=target/compare-$SCENE-$N
cargo build --release -q -p gonio
G=target/release/gonio
if [ ! -f "$DIR/frames.raw" ]; then
    $G simulate frames --scene "$SCENE" --count "$N" --seed 1 --raw --out "$DIR" 2>/dev/null
fi
CORE=0
PIN=()
if command -v taskset >/dev/null; then PIN=(taskset -c $CORE); fi

# gonio: two passes (the first warms the page cache), the second timed.
"${PIN[@]}" $G detect --raw 1440x540 --threads 1 <"$DIR/frames.raw" >/dev/null 2>&1
TIMES=$( { TIMEFORMAT='%U %S %R'; time "${PIN[@]}" $G detect --raw 1440x540 --threads 1 \
    <"$DIR/frames.raw" >"$DIR/gonio.jsonl" 2>/dev/null; } 2>&1 )
read -r U S R <<<"$TIMES"
GONIO_MS=$(python3 -c "print(f'{($U + $S) * 1e3 / $N:.3f}')")
GONIO_WALL=$(python3 -c "print(f'{$R * 1e3 / $N:.3f}')")

# gonio, the same scope as OpenCV's figure: the detector's median CPU time per frame.
TIMING=$("${PIN[@]}" $G detect --raw 1440x540 --timing <"$DIR/frames.raw" 2>&1 >/dev/null |
    grep '^detector alone')
GONIO_DET_MS=$(sed -E 's/.*median ([0-9.]+) ms.*/\1/' <<<"$TIMING")

OPENCV_JSON=$("${PIN[@]}" python3 bench/opencv_reference.py "$DIR/frames.raw" --json)
OPENCV_MS=$(python3 -c "import json,sys; print(f\"{json.loads(sys.argv[1])['per_frame_ms_median']:.3f}\")" "$OPENCV_JSON")

python3 - "$OPENCV_JSON" "$GONIO_MS" "$GONIO_WALL" "$N" "$SCENE" "$GONIO_DET_MS" <<'EOF'
import json, sys
cv = json.loads(sys.argv[1])
g, gw, n, scene = float(sys.argv[2]), float(sys.argv[3]), int(sys.argv[4]), sys.argv[5]
gd = float(sys.argv[6])
print(f"{n} frames of the `{scene}` scene, 1440x540, one core each")
print(f"  OpenCV {cv['opencv']} (numpy {cv['numpy']}), seed's stages: {cv['per_frame_ms_median']:8.3f} ms/frame (CPU, median)")
for s, v in cv["stages_ms_median"].items():
    print(f"      {s:34} {v:8.3f} ms")
print(f"  gonio detector alone (--timing):     {gd:8.3f} ms/frame (CPU, median)")
print(f"  gonio detect --threads 1, end to end: {g:7.3f} ms/frame (CPU incl. reading and JSON; wall {gw:.3f} ms)")
print(f"  ratio OpenCV / gonio, same scope:    {cv['per_frame_ms_median'] / gd:8.1f}x")
print(f"  ratio OpenCV / gonio end to end:     {cv['per_frame_ms_median'] / g:8.1f}x")
EOF
