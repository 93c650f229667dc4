# bash completion for drivetap (installed as share/bash-completion/completions/drivetap).
# Commands, then each command's own options as its --help lists them (never out of date), values
# of the options with a fixed set, serial ports after -i, files elsewhere.
_drivetap() {
  local cur prev words cword
  _init_completion 2>/dev/null || {
    cur="${COMP_WORDS[COMP_CWORD]}"
    prev="${COMP_WORDS[COMP_CWORD - 1]}"
    words=("${COMP_WORDS[@]}")
    cword=$COMP_CWORD
  }
  local commands="decode read diagnose capture generate profiles report wireshark"
  local command="" i
  for ((i = 1; i < cword; i++)); do
    case " $commands " in *" ${words[i]} "*) command="${words[i]}"; break ;; esac
  done
  case "$prev" in
    -T | --format) COMPREPLY=($(compgen -W "text json" -- "$cur")); return ;;
    -t) COMPREPLY=($(compgen -W "ad a r d dd e u ud" -- "$cur")); return ;;
    --color) COMPREPLY=($(compgen -W "auto always never" -- "$cur")); return ;;
    -P | --protocol) COMPREPLY=($(compgen -W "auto rtu ascii fc eds" -- "$cur")); return ;;
    --dlt) COMPREPLY=($(compgen -W "upper-pdu user0" -- "$cur")); return ;;
    -i | --interface)
      COMPREPLY=($(compgen -W "$(ls /dev/ttyUSB* /dev/ttyACM* /dev/ttyS* 2>/dev/null)" -- "$cur"))
      return ;;
    -s | --serial | --t15 | --t35 | --timeout | --max-hold | -c | --count | --drive | --channels)
      return ;;
  esac
  if [ -z "$command" ]; then
    if [[ "$cur" == -* ]]; then
      COMPREPLY=($(compgen -W "-r -i -D --help --version" -- "$cur"))
    else
      COMPREPLY=($(compgen -W "$commands" -- "$cur"))
    fi
    return
  fi
  if [[ "$cur" == -* ]]; then
    local options
    options=$("${words[0]}" "$command" --help 2>/dev/null |
      grep -E '^  -' | awk '{print $1}' | tr ',' '\n' | sort -u)
    COMPREPLY=($(compgen -W "$options" -- "$cur"))
    return
  fi
  COMPREPLY=($(compgen -f -- "$cur"))
}
complete -o filenames -F _drivetap drivetap
