#!/usr/bin/env bash
# Issues 48 and 49 measured on a machine with many cores, in one run that stops by a deadline
# (each step runs only while time is left, most important first):
#   0. how fast the machine writes a synced gigabyte (a release build writes ~1.2 GB a scene);
#   1. a 12-scene release at 1200x680 (configs/release-full.toml with 8 furniture and 4 manipuland
#      scenes, 4 + 2 of them the hidden test split from a fixed secret) built on every core, timed
#      with its peak memory, once for each of BUILDS (scenes at once : cap in seconds); its
#      progress lines say when each scene finished, and a line every 10 s what it has written;
#   2. the reference mapper and its geometry-only twin on that release (when a build finished),
#      each scored with `osmab client validate` (the local build holds the test split's ground truth);
#   3. whole-submission scoring (`osmab bench submission --warm-node`, 8 scenes of the full sizes)
#      at 16, 8, 4, 2 and 1 threads;
#   4. the thread scaling of a release build (2 scenes at the demo's render settings) at 16, 8, 4,
#      2 and 1 threads with bench/release_scaling.py.
# Logs go to OUT; the releases are removed.
#
# Usage: [STEPS=disk,build,mapper,scoring,scaling] [BUILDS="default:200 2:120"] \
#            bench/many_cores.sh OSMAB OUT [DEADLINE_S] [BUILD_CAP_S]
#   e.g. bench/many_cores.sh target/release/osmab /tmp/many-cores 560 300
# (STEPS picks the steps. SCENES="F M TF TM" and SIZE="W H" change step 1's release, e.g.
# SCENES="2 1 1 0" SIZE="160 90" for a quick try of the script.)
set -u
osmab=$(realpath "$1")
out=$2
deadline=${3:-560}
build_cap=${4:-300}
work=${WORK:-/tmp/many-cores-work}
mkdir -p "$out" "$work"
start=$(date +%s)
left() { echo $((deadline - ($(date +%s) - start))); }
steps=${STEPS:-disk,build,mapper,scoring,scaling}
want() { [[ ",$steps," == *",$1,"* ]]; }
export OSMAB_SPLIT_SECRET=many-cores-secret-0001 PYTHONUNBUFFERED=1

{
    echo "## machine"
    nproc
    lscpu | grep -E 'Model name|^CPU\(s\)|Thread|Socket|MHz' || grep -m1 'model name' /proc/cpuinfo
    free -g | head -2
    df -h "$work" | tail -1
} > "$out/machine.txt" 2>&1
cat "$out/machine.txt"

if want disk; then
    echo "## 0. how fast this machine writes (1 GB, synced)"
    timeout 60 dd if=/dev/zero of="$work/dd" bs=1M count=1000 conv=fdatasync 2>&1 | tail -1
    rm -f "$work/dd"
fi

if want build; then
read -r f m tf tm <<< "${SCENES:-8 4 4 2}"
read -r width height <<< "${SIZE:-1200 680}"
sed -e "s/^furniture = 24/furniture = $f/" -e "s/^manipuland = 16/manipuland = $m/" \
    -e "s/^test_furniture = 12/test_furniture = $tf/" -e "s/^test_manipuland = 8/test_manipuland = $tm/" \
    -e "s/^width = 1200/width = $width/" -e "s/^height = 680/height = $height/" \
    configs/release-full.toml > "$work/twelve.toml"
# BUILDS: each "AT_ONCE:CAP" builds the release with that many scenes at once ("default":
# the build's own choice) for at most CAP seconds; the last one's release stays for step 2.
for build in ${BUILDS:-default:$build_cap}; do
    at_once=${build%%:*}
    cap=${build##*:}
    log="$out/build_$at_once.log"
    echo "## 1. a release of $f + $m scenes ($tf + $tm test) at ${width}x$height on $(nproc) threads, $at_once scenes at once (cap $cap s)"
    rm -rf "$work/twelve"
    ( [ "$at_once" = default ] || export OSMAB_RELEASE_SCENES_AT_ONCE=$at_once
      python3 bench/peak_rss.py timeout "$cap" "$osmab" release build --config "$work/twelve.toml" --out "$work/twelve" > "$log" 2>&1
      echo "exit $? after $(($(date +%s) - start)) s" ) &
    built=$!
    # What the build has written, every 10 s: its pace.
    began=$(date +%s)
    while kill -0 $built 2> /dev/null; do
        sleep 10
        echo "[$(($(date +%s) - began)) s] $(du -sb "$work/twelve" 2> /dev/null | awk '{printf "%.2f GB written", $1 / 1e9}')" >> "$log.pace"
    done
    wait $built
    grep -E 'scene_[0-9]+: ([0-9]+ frames|rendering baseline)|release |Maximum resident|Elapsed' "$log" | tail -30
    cat "$log.pace"
done
fi

echo "## 2. the reference mapper and its twin on it"
for variant in seeing geometry; do
    want mapper || continue
    if [ "$(left)" -lt 90 ] || [ ! -f "$work/twelve/manifest.json" ]; then echo "skipped $variant"; continue; fi
    flag=$([ $variant = geometry ] && echo --geometry-only)
    python3 bench/peak_rss.py timeout $(($(left) - 60)) "$osmab" baseline perceive --release "$work/twelve" --out "$work/sub_$variant" $flag \
        > "$out/perceive_$variant.log" 2>&1
    tail -3 "$out/perceive_$variant.log"
    timeout $(($(left) - 30)) "$osmab" client validate "$work/sub_$variant" --release-dir "$work/twelve" \
        > "$out/validate_$variant.log" 2>&1
    grep -iE 'miou|split|baseline|camera|dynamic|no_lights|vqa' "$out/validate_$variant.log" | head -30
done
rm -rf "$work/twelve" "$work"/sub_*

echo "## 3. a whole submission (8 scenes of the full sizes), warm node, by threads"
for t in 16 8 4 2 1; do
    want scoring || continue
    if [ "$(left)" -lt 50 ]; then echo "skipped $t threads: $(left) s left"; continue; fi
    echo "### $t threads"
    RAYON_NUM_THREADS=$t timeout $(($(left) - 20)) "$osmab" bench submission --data "$work/submission" --scenes 8 --warm-node \
        > "$out/submission_t$t.log" 2>&1
    grep -E 'node made ready|whole submission|associate|run 0' "$out/submission_t$t.log"
done
rm -rf "$work/submission"

echo "## 4. release build scaling: 2 scenes at the demo's render settings"
sed -e 's/^furniture = 4/furniture = 1/' -e 's/^manipuland = 3/manipuland = 1/' -e '/^\[splits\]/,$d' \
    configs/release-demo.toml > "$work/two.toml"
for t in 16 8 4 2 1; do
    want scaling || continue
    if [ "$(left)" -lt 40 ]; then echo "skipped $t threads: $(left) s left"; continue; fi
    timeout $(($(left) - 10)) python3 bench/release_scaling.py "$osmab" "$work/two.toml" "$work/scaling" --threads "$t" \
        > "$out/scaling_t$t.log" 2>&1
    grep -h '^{' "$out/scaling_t$t.log"
done
echo "done after $(($(date +%s) - start)) s"
