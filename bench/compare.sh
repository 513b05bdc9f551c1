#!/usr/bin/env bash
# The ring detector against the seed's stages in OpenCV, on the same frames, one core each:
# per-frame time of both and the ratio, in one run. A benchmark, not part of .ci/run.
#
#   bench/compare.sh [FRAMES] [SCENE] [ROUNDS]   (defaults: 200 frames of the `dense` scene, 3 rounds)
#   PROFILE=release bench/compare.sh …           (gonio's release build instead of `dist`)
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
# wall-clock figures. A virtual machine's host still slows both for seconds at a time, so the
# same-scope pair is measured ROUNDS times, gonio and OpenCV alternated round by round: each
# round's figures and ratio are printed, and the ratio of the two sides' medians over the rounds.
set -euo pipefail
cd "$(dirname "$0")/.."
N=${1:-200}
SCENE=${2:-dense}
DIR=target/compare-$SCENE-$N
# gonio as shipped for speed: the `dist` profile (fat LTO, one codegen unit; see Cargo.toml).
# PROFILE=release compares the plain release build instead.
PROFILE=${PROFILE:-dist}
cargo build --profile "$PROFILE" -q -p gonio
G=target/$PROFILE/gonio
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

# The same scope, ROUNDS times, alternated: gonio's detector (its median CPU time per frame),
# then OpenCV's stages (theirs).
ROUNDS=${3:-3}
DET_MS=()
CV_JSON=()
for ((r = 0; r < ROUNDS; r++)); do
    TIMING=$("${PIN[@]}" $G detect --raw 1440x540 --timing <"$DIR/frames.raw" 2>&1 >/dev/null |
        grep '^detector alone')
    DET_MS+=("$(sed -E 's/.*median ([0-9.]+) ms.*/\1/' <<<"$TIMING")")
    CV_JSON+=("$("${PIN[@]}" python3 bench/opencv_reference.py "$DIR/frames.raw" --json)")
done

python3 - "$GONIO_MS" "$GONIO_WALL" "$N" "$SCENE" "$PROFILE" "${DET_MS[*]}" "${CV_JSON[@]}" <<'EOF'
import json, statistics, sys
g, gw, n, scene = float(sys.argv[1]), float(sys.argv[2]), int(sys.argv[3]), sys.argv[4]
profile = sys.argv[5]
det = [float(x) for x in sys.argv[6].split()]
cvs = [json.loads(a) for a in sys.argv[7:]]
cv_ms = [c["per_frame_ms_median"] for c in cvs]
gd, cm = statistics.median(det), statistics.median(cv_ms)
cv = cvs[0]
print(f"{n} frames of the `{scene}` scene, 1440x540, one core each, {len(det)} alternated rounds (gonio: `{profile}` build)")
for k, (d, c) in enumerate(zip(det, cv_ms)):
    print(f"  round {k + 1}: OpenCV {c:7.3f} ms/frame, gonio {d:6.3f} ms/frame, ratio {c / d:6.2f}x")
print(f"  OpenCV {cv['opencv']} (numpy {cv['numpy']}), seed's stages: {cm:8.3f} ms/frame (CPU, median of the rounds' medians)")
for s, v in cv["stages_ms_median"].items():
    print(f"      {s:34} {v:8.3f} ms (round 1)")
print(f"  gonio detector alone (--timing):     {gd:8.3f} ms/frame (CPU, median of the rounds' medians)")
print(f"  gonio detect --threads 1, end to end: {g:7.3f} ms/frame (CPU incl. reading and JSON; wall {gw:.3f} ms)")
print(f"  ratio OpenCV / gonio, same scope:    {cm / gd:8.2f}x")
print(f"  ratio OpenCV / gonio end to end:     {cm / g:8.2f}x")
EOF
