#!/usr/bin/env bash
# Packs the GPU builds of the benchmarks (palpa-render-bench-gpu,
# palpa-loop-bench-gpu), the scripted device plugin and every shared library
# they load from Debian 12 into one tarball, with a run.sh, so that issue 8's
# target 5 can be measured on a machine with an NVIDIA driver that has none of
# Palpa's packages (any x86-64 glibc >= 2.36 distribution). Never used in CI.
#
# Left out, because the machine's own must be used: glibc (libc, libm, ld.so)
# and the driver's GL stack. glvnd's dispatch libraries (libEGL, libOpenGL,
# libGL, libGLX, libGLdispatch) and libstdc++/libgcc_s go into lib-fallback/,
# which run.sh uses only for what the machine lacks.
#
# Usage: tools/gpu-bench-bundle.sh OUT.tar.xz   (after building both targets:
#        cmake --build build --target palpa-render-bench-gpu palpa-loop-bench-gpu)
set -euo pipefail
out=${1:?usage: tools/gpu-bench-bundle.sh OUT.tar.xz}
case "$out" in /*) ;; *) out="$PWD/$out" ;; esac  # relative to the caller's folder
cd "$(dirname "$0")/.."

bins=(build/bin/palpa-render-bench-gpu build/bin/palpa-loop-bench-gpu)
plugin=build/plugins/libpalpa_device_scripted.so
for f in "${bins[@]}" "$plugin"; do
  [ -f "$f" ] || { echo "gpu-bench-bundle: $f is missing; build palpa-render-bench-gpu and palpa-loop-bench-gpu first" >&2; exit 1; }
done

stage=$(mktemp -d)
trap 'rm -rf "$stage"' EXIT
root="$stage/palpa-gpu-bench"
mkdir -p "$root/bin" "$root/plugins" "$root/lib" "$root/lib-fallback"
cp "${bins[@]}" "$root/bin/"
cp "$plugin" "$root/plugins/"

# Every library ldd resolves for the programs and the plugin; one it cannot
# find here would be missing there too.
deps=$(ldd "${bins[@]}" "$plugin")
if grep -q 'not found' <<<"$deps"; then
  echo "gpu-bench-bundle: ldd cannot find some libraries here:" >&2
  grep 'not found' <<<"$deps" | sort -u >&2
  exit 1
fi
awk '$2 == "=>" && $3 ~ /^\// {print $1, $3}' <<<"$deps" | sort -u |
  while read -r name path; do
    case "$name" in
      # glibc's own libraries: the machine's must be used, with its ld.so
      libc.so.*|libm.so.*|libmvec.so.*|libdl.so.*|librt.so.*|libpthread.so.*|libresolv.so.*|libutil.so.*|\
      libanl.so.*|libnsl.so.*|libnss_*|libthread_db.so.*|libBrokenLocale.so.*|libc_malloc_debug.so.*|ld-linux*) ;;
      libEGL.so.*|libOpenGL.so.*|libGL.so.*|libGLX.so.*|libGLdispatch.so.*|libstdc++.so.*|libgcc_s.so.*)
        cp -L "$path" "$root/lib-fallback/$name" ;;
      *) cp -L "$path" "$root/lib/$name" ;;
    esac
  done

cat >"$root/run.sh" <<'EOF'
#!/usr/bin/env bash
# Runs Palpa's GPU benchmarks from this bundle (tools/gpu-bench-bundle.sh).
# Usage: run.sh [RESULTS_DIR] [LOOP_SECONDS]
here=$(cd "$(dirname "$0")" && pwd)
results=${1:-$PWD}
seconds=${2:-20}
mkdir -p "$results"
export LD_LIBRARY_PATH="$here/lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}"
export PALPA_PLUGIN_PATH="$here/plugins"
export PALPA_GL=egl
missing() { ldd "$here/bin/palpa-render-bench-gpu" "$here/bin/palpa-loop-bench-gpu" "$here/plugins/"*.so | grep 'not found' | sort -u; }
if [ -n "$(missing)" ]; then
  echo "run.sh: the machine lacks $(missing | awk '{print $1}' | tr '\n' ' '); using the bundle's own"
  export LD_LIBRARY_PATH="$LD_LIBRARY_PATH:$here/lib-fallback"
fi
if [ -n "$(missing)" ]; then echo "run.sh: still missing:"; missing; exit 1; fi
{
  echo "== machine"; uname -srm; grep PRETTY_NAME /etc/os-release; nproc
  command -v nvidia-smi >/dev/null && nvidia-smi --query-gpu=name,driver_version,clocks.sm,clocks.mem --format=csv
} 2>&1 | tee "$results/machine.txt"
set -o pipefail
echo "== palpa-render-bench-gpu, 1024x768" | tee "$results/render.txt"
"$here/bin/palpa-render-bench-gpu" --gl egl --triangles 1000000,2000000 --frames 40 --json "$results/render.json" 2>&1 | tee -a "$results/render.txt"
echo "== palpa-render-bench-gpu, 1920x1080" | tee "$results/render-1080.txt"
"$here/bin/palpa-render-bench-gpu" --gl egl --size 1920x1080 --triangles 1000000,2000000 --frames 40 2>&1 | tee -a "$results/render-1080.txt"
echo "== palpa-loop-bench-gpu, $seconds s per run" | tee "$results/loop.txt"
"$here/bin/palpa-loop-bench-gpu" --seconds "$seconds" --rates 1000,4000 2>&1 | tee -a "$results/loop.txt"
EOF
chmod +x "$root/run.sh"

tar -C "$stage" -cJf "$out" palpa-gpu-bench
echo "gpu-bench-bundle: $out ($(du -h "$out" | cut -f1); $(ls "$root/lib" | wc -l) libraries, $(ls "$root/lib-fallback" | wc -l) fallbacks)"
