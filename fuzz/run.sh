#!/usr/bin/env bash
# Runs one fuzz target with the limits of RELIABILITY.md, then prints its summary.
#   fuzz/run.sh TARGET [SECONDS] [RUNS]     (defaults: 1800 s, 1,000,000 executions)
# One target at a time, one job, nice'd: the machine is shared.
set -euo pipefail
cd "$(dirname "$0")"
target=$1
secs=${2:-1800}
runs=${3:-1000000}
case $target in
  obj|obj_variants) dict=obj ;; off) dict=off ;; ply_ascii|ply_binary|ply_variants) dict=ply ;;
  stl_ascii|stl_binary) dict=stl ;; mtx) dict=mtx ;; npy) dict=npy ;; *) dict= ;;
esac
mkdir -p "corpus/$target" logs
# Suspect meshes of the detector are whole PLY files (8 KB for the seeds).
maxlen=8192; [ "$target" = watermark_detect ] && maxlen=65536
args=(-rss_limit_mb=1024 -malloc_limit_mb=1024 -timeout=1 -max_len=$maxlen
      -runs="$runs" -max_total_time="$secs" -print_final_stats=1)
[ -n "$dict" ] && args+=(-dict="dict/$dict.dict")
nice -n 10 cargo +nightly fuzz run "$target" "corpus/$target" -- "${args[@]}" \
  2>&1 | tee "logs/$target.log" | grep -E "^#[0-9]+ +(DONE|pulse)|ERROR|panicked|stat::" || true
