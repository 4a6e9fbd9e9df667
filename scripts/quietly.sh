#!/usr/bin/env bash
# quietly.sh NAME COMMAND...: runs COMMAND with its output (stdout and stderr) in
# $VFRS_TEST_LOGS/NAME.log (default target/test-logs/), printing nothing when it succeeds; when it
# fails, prints that log and its exit status and exits with that status. scripts/test_all.sh runs
# its noisy steps (install, cargo, the documentation build) through it: a green run is quiet.
set -uo pipefail
name=$1
shift
logs=${VFRS_TEST_LOGS:-target/test-logs}
mkdir -p "$logs"
log="$logs/$name.log"
"$@" >"$log" 2>&1
status=$?
if [ "$status" -ne 0 ]; then
    cat "$log" >&2
    echo "FAILED ($name, exit $status): $* -- its whole output above, also in $log" >&2
fi
exit "$status"
