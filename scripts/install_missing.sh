# Sourced by the setup scripts: install_missing PKG... apt-get installs the
# Debian packages among its arguments that are not installed yet (running
# `apt-get update` once first, since a fresh machine's lists may be empty),
# with sudo when not root. Does nothing when all are installed.
install_missing() {
  local missing=() p
  for p in "$@"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
  done
  [ ${#missing[@]} -eq 0 ] && return 0
  echo "setup: installing ${missing[*]}"
  local sudo_cmd=()
  [ "$(id -u)" -ne 0 ] && sudo_cmd=(sudo)
  if [ -z "${GRADRASTER_APT_UPDATED:-}" ]; then
    "${sudo_cmd[@]}" apt-get update -qq
    GRADRASTER_APT_UPDATED=1
  fi
  DEBIAN_FRONTEND=noninteractive "${sudo_cmd[@]}" apt-get install -y -qq "${missing[@]}"
}
