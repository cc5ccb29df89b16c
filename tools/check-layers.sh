#!/usr/bin/env bash
# Checks the layers: every module in modules/ and every device plugin in
# plugins/devices/ includes headers only of the modules its CMake target
# links, and links exactly the modules it includes:
#   - a header (.h) may include "X/..." only when X is linked PUBLIC;
#   - a source (.cpp) may include "X/..." when X is linked PUBLIC or PRIVATE;
#   - a module linked PUBLIC must be included by one of the unit's headers,
#     one linked PRIVATE by one of its files (otherwise the link says more
#     than the code uses);
#   - no unit includes headers of app/, tests/, bench/ or tools/;
#   - a grant target (palpa::plugin_api) allows only the headers it names.
# What each target links is read by CMake from the targets themselves and
# written to <build>/palpa_layers.txt (tools/layers.cmake).
#
# Usage: tools/check-layers.sh [LAYERS_FILE [SOURCE_DIR]]
#        (defaults: build/palpa_layers.txt, the checkout this script is in)
#        tools/check-layers.sh --self-test   (shows that a wrong include fails)
set -euo pipefail

here="$(cd "$(dirname "$0")/.." && pwd)"

check() {
  local layers="$1" root="$2"
  if [ ! -f "$layers" ]; then
    echo "check-layers: $layers not found (configure with CMake first)" >&2
    return 2
  fi
  local dirs
  dirs=$(awk -F'|' '$1 == "unit" { print $3 }' "$layers")
  # One line per quoted include of a folder-qualified header: FILE|HEADER.
  (cd "$root" && for d in $dirs; do
     [ -d "$d" ] || continue
     grep -rHE --include='*.h' --include='*.hpp' --include='*.cpp' --include='*.cc' \
       '^[[:space:]]*#[[:space:]]*include[[:space:]]*"[^"/]+/[^"]*"' "$d" || true
   done) |
  sed -E 's/^([^:]+):[[:space:]]*#[[:space:]]*include[[:space:]]*"([^"]*)".*/\1|\2/' |
  awk -F'|' -v layers="$layers" '
    BEGIN {
      while ((getline line < layers) > 0) {
        if (line ~ /^#/ || line == "") continue
        n = split(line, f, "|")
        if (f[1] == "module") { is_module[f[2]] = 1 }
        else if (f[1] == "grant") {
          grant_module[f[2]] = f[3]
          k = split(f[4], h, ",")
          for (i = 1; i <= k; ++i) grants[f[2] SUBSEP h[i]] = 1
        } else if (f[1] == "unit") {
          units[++nunits] = f[2]
          dir[f[2]] = f[3]
          own[f[2]] = (f[3] ~ /^modules\//) ? f[2] : ""
          tgt[f[2]] = f[4]
          k = split(f[5], d, ",")
          for (i = 1; i <= k; ++i) if (d[i] != "") { pub[f[2] SUBSEP d[i]] = 1; dep[f[2] SUBSEP d[i]] = "PUBLIC" }
          k = split(f[6], d, ",")
          for (i = 1; i <= k; ++i) if (d[i] != "") { dep[f[2] SUBSEP d[i]] = "PRIVATE" }
        }
      }
      foreign["app"] = foreign["tests"] = foreign["bench"] = foreign["tools"] = foreign["plugins"] = 1
      errors = 0
    }
    # The unit whose folder holds the file (the longest matching folder).
    function unit_of(file,   u, best) {
      best = ""
      for (i = 1; i <= nunits; ++i) {
        u = units[i]
        if (index(file, dir[u] "/") == 1 && length(dir[u]) > length(dir[best])) best = u
      }
      return best
    }
    function target(u) { return tgt[u] }
    {
      file = $1; header = $2
      u = unit_of(file)
      if (u == "") next
      is_header = (file ~ /\.(h|hpp)$/)
      m = header; sub(/\/.*/, "", m)
      if (m in foreign) {
        printf "%s: includes \"%s\": a module or plugin never includes %s/\n", file, header, m
        ++errors; next
      }
      if (!(m in is_module) || m == own[u]) next
      # A whole module linked, or a grant of exactly this header.
      ok = ""
      if ((u SUBSEP m) in dep) { ok = m }
      else for (g in grant_module)
        if (grant_module[g] == m && ((g SUBSEP header) in grants) && ((u SUBSEP g) in dep)) ok = g
      if (ok == "") {
        printf "%s: includes \"%s\" but %s does not link palpa::%s\n", file, header, target(u), m
        ++errors; next
      }
      if (is_header && !((u SUBSEP ok) in pub)) {
        printf "%s: header includes \"%s\" but %s links palpa::%s PRIVATE (make it PUBLIC)\n", file, header, target(u), ok
        ++errors; next
      }
      used[u SUBSEP ok] = 1
      if (is_header) used_pub[u SUBSEP ok] = 1
    }
    END {
      for (key in dep) {
        split(key, p, SUBSEP)
        if (p[2] == own[p[1]]) continue
        if (dep[key] == "PUBLIC" && !(key in used_pub)) {
          if (key in used)
            printf "%s: links palpa::%s PUBLIC but only its sources include it (make it PRIVATE)\n", target(p[1]), p[2]
          else
            printf "%s: links palpa::%s PUBLIC but includes none of its headers (drop it)\n", target(p[1]), p[2]
          ++errors
        } else if (dep[key] == "PRIVATE" && !(key in used)) {
          printf "%s: links palpa::%s PRIVATE but includes none of its headers (drop it)\n", target(p[1]), p[2]
          ++errors
        }
      }
      if (errors) { printf "check-layers: %d problem(s); see the table in %s\n", errors, layers; exit 1 }
      printf "check-layers: %d modules and plugins include only what they link, and link only what they include\n", nunits
    }'
}

self_test() {
  local t
  t=$(mktemp -d)
  trap 'rm -rf "$t"' RETURN
  mkdir -p "$t/modules/low" "$t/modules/high" "$t/modules/api" "$t/plugins/devices/p"
  printf '#pragma once\n' > "$t/modules/low/low.h"
  printf '#pragma once\n' > "$t/modules/api/open.h"
  printf '#pragma once\n' > "$t/modules/api/closed.h"
  printf '#pragma once\n#include "low/low.h"\n' > "$t/modules/high/high.h"
  printf '#include "api/open.h"\n' > "$t/plugins/devices/p/p.cpp"
  cat > "$t/good.txt" <<'EOF'
module|low
module|high
module|api
grant|plugin_api|api|api/open.h
unit|low|modules/low|palpa_low||
unit|high|modules/high|palpa_high|low|
unit|api|modules/api|palpa_api||
unit|p|plugins/devices/p|palpa_device_p||plugin_api
EOF
  local out
  out=$(check "$t/good.txt" "$t") || { echo "self-test: a correct tree failed:"; echo "$out"; return 1; }
  # Each case: a change to the tree or the table, and the message it must give.
  expect_fail() {
    local what="$1" layers="$2" pattern="$3"
    if out=$(check "$layers" "$t"); then
      echo "self-test: $what passed; it must fail"; return 1
    fi
    if ! grep -qF "$pattern" <<<"$out"; then
      echo "self-test: $what failed without saying: $pattern"; echo "$out"; return 1
    fi
  }
  sed 's/^unit|high|modules\/high|palpa_high|low|$/unit|high|modules\/high|palpa_high||/' "$t/good.txt" > "$t/nolink.txt"
  expect_fail "an include of a module not linked" "$t/nolink.txt" \
    'modules/high/high.h: includes "low/low.h" but palpa_high does not link palpa::low'
  sed 's/^unit|high|modules\/high|palpa_high|low|$/unit|high|modules\/high|palpa_high||low/' "$t/good.txt" > "$t/private.txt"
  expect_fail "a header including a PRIVATE module" "$t/private.txt" 'links palpa::low PRIVATE (make it PUBLIC)'
  sed 's/^unit|low|modules\/low|palpa_low||$/unit|low|modules\/low|palpa_low|api|/' "$t/good.txt" > "$t/unused.txt"
  expect_fail "a link no include uses" "$t/unused.txt" 'palpa_low: links palpa::api PUBLIC but includes none'
  printf '#include "api/closed.h"\n' > "$t/plugins/devices/p/q.cpp"
  expect_fail "a plugin including a header its grant does not name" "$t/good.txt" \
    'plugins/devices/p/q.cpp: includes "api/closed.h" but palpa_device_p does not link palpa::api'
  rm "$t/plugins/devices/p/q.cpp"
  printf '#include "tests/x.h"\n' > "$t/modules/low/low.cpp"
  expect_fail "an include of tests/" "$t/good.txt" 'never includes tests/'
  echo "check-layers self-test: a correct tree passes; wrong includes and links fail with their message"
}

if [ "${1:-}" = "--self-test" ]; then
  self_test
else
  check "${1:-$here/build/palpa_layers.txt}" "${2:-$here}"
fi
