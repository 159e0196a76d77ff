# bash completion for scaratwin, scaratwin-sim and scaratwin-robot: subcommands, statements and
# options, read from the programs' own --help (so it follows the command line as it changes),
# file names for the options and arguments that take files. Installed to
# <prefix>/share/bash-completion/completions/ (bash-completion loads it on first use); or
# `source` this file.

# the words of a --help listing: subcommand names (section "Subcommands" or "Statements") or
# option names (section "Options")
_scaratwin_help_words() {
  local what=$1
  shift
  "$@" --help 2>/dev/null | awk -v what="$what" '
    /^[A-Za-z].*:$/ { section = $0; next }
    what == "commands" && (section == "Subcommands:" || section == "Statements:") &&
      /^  [a-z]/ { print $1 }
    what == "options" && section == "Options:" && /^  -/ {
      n = split($1, names, ",")
      for (i = 1; i <= n; i++) { sub(/=.*/, "", names[i]); print names[i] }
    }'
}

_scaratwin() {
  local cur prev
  cur=${COMP_WORDS[COMP_CWORD]}
  prev=${COMP_WORDS[COMP_CWORD - 1]}
  local prog=${COMP_WORDS[0]}

  # options that take a file or a folder
  case $prev in
    --config | --scenario | --profile | --firmware | --db | --csv | --save | --png | --json-out | \
      --mcap)
      COMPREPLY=($(compgen -f -- "$cur"))
      return
      ;;
    --out | --web-root | --save-images | --artifacts)
      COMPREPLY=($(compgen -d -- "$cur"))
      return
      ;;
    --serial)
      COMPREPLY=($(compgen -f -- "${cur:-/dev/tty}"))
      return
      ;;
  esac

  # the subcommand: the first word after the program that is not an option
  local sub="" i
  if [[ ${prog##*/} == scaratwin ]]; then
    for ((i = 1; i < COMP_CWORD; i++)); do
      if [[ ${COMP_WORDS[i]} != -* ]]; then
        sub=${COMP_WORDS[i]}
        break
      fi
    done
  fi

  local -a cmd=("$prog")
  [[ -n $sub ]] && cmd+=("$sub")
  if [[ $cur == -* ]]; then
    COMPREPLY=($(compgen -W "$(_scaratwin_help_words options "${cmd[@]}")" -- "$cur"))
  elif [[ ${prog##*/} == scaratwin && -z $sub ]]; then
    COMPREPLY=($(compgen -W "$(_scaratwin_help_words commands "$prog")" -- "$cur"))
  else
    case $sub in
      run | report | runs | shoot) COMPREPLY=($(compgen -f -- "$cur")) ;;
      spawn) [[ $prev == spawn ]] && COMPREPLY=($(compgen -W "red green blue" -- "$cur")) ;;
    esac
  fi
}

complete -F _scaratwin scaratwin scaratwin-sim scaratwin-robot
