#!/usr/bin/env bash
# The bash completion (scripts/completion/scaratwin.bash) against the built command line:
#   completion_test.sh COMPLETION_FILE BIN_DIR
set -euo pipefail
# shellcheck source=/dev/null
source "$1"
PATH=$2:$PATH
fail=0
expect() {  # expect WANTED WORD...: completing WORD... offers WANTED
  local wanted=$1
  shift
  COMP_WORDS=("$@")
  COMP_CWORD=$((${#COMP_WORDS[@]} - 1))
  COMPREPLY=()
  _scaratwin
  if [[ " ${COMPREPLY[*]} " != *" $wanted "* ]]; then
    echo "FAIL: completing '$*' offers '${COMPREPLY[*]}', not '$wanted'"
    fail=1
  else
    echo "ok: '$*' -> ${COMPREPLY[*]}"
  fi
}
expect fk scaratwin ""
expect demo scaratwin de
expect movej scaratwin mov
expect --all scaratwin ik --a
expect --keep-open scaratwin demo --k
expect --http-port scaratwin sim --http
expect --port scaratwin-sim --po
expect red scaratwin spawn r
expect --version scaratwin --ver
if [[ -x $2/scaratwin-robot ]]; then
  expect --firmware scaratwin robot --firm
  expect --side-port scaratwin-robot --side
fi
exit $fail
