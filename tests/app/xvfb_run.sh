#!/bin/sh
# Runs a command under a private Xvfb server that this script starts and
# stops. Xvfb picks a free display number itself (-displayfd), so parallel
# test runs do not collide. Used as the launcher of the GUI tests; if the
# script is stopped (ctest timeout), it stops the command and Xvfb too.
tmp=$(mktemp -d) || exit 1
xvfb=
child=
cleanup() {
  [ -n "$child" ] && kill "$child" 2>/dev/null
  [ -n "$xvfb" ] && kill "$xvfb" 2>/dev/null
  rm -rf "$tmp"
}
trap 'cleanup; exit 143' TERM INT HUP

Xvfb -displayfd 3 -screen 0 1280x1024x24 -nolisten tcp -noreset 3>"$tmp/display" 2>"$tmp/xvfb.log" &
xvfb=$!
i=0
while [ ! -s "$tmp/display" ] && [ $i -lt 200 ]; do
  sleep 0.05
  i=$((i + 1))
done
if [ ! -s "$tmp/display" ]; then
  echo "xvfb_run.sh: Xvfb did not start:" >&2
  cat "$tmp/xvfb.log" >&2
  cleanup
  exit 1
fi
DISPLAY=":$(head -n 1 "$tmp/display")"
export DISPLAY

"$@" &
child=$!
wait "$child"
rc=$?
child=
cleanup
exit $rc
