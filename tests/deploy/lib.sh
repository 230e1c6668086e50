# Shared by tests/deploy/run.sh: the container engine (podman with runc and cgroupfs, explicit
# ulimits: this machine class refuses crun and podman's default limits) and the Debian base
# images, made locally with debootstrap because there is no image registry here.
P=(podman --runtime runc --cgroup-manager=cgroupfs)
ULIMITS=(--ulimit nofile=1024:4096 --ulimit nproc=1024:4096)

log() { printf 'deploy: %s\n' "$*" >&2; }
fail() { log "FAILED: $*"; exit 1; }

install_tools() {
  local wanted=(podman runc debootstrap haproxy prometheus) missing=()
  for p in "${wanted[@]}"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
  done
  [ ${#missing[@]} -eq 0 ] && return 0
  [ "$(id -u)" -eq 0 ] || fail "missing packages ${missing[*]}: run as root or install them"
  log "installing ${missing[*]}"
  DEBIAN_FRONTEND=noninteractive apt-get update -qq
  DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends "${missing[@]}"
}

# The first Debian mirror apt uses (deb822 or one-line sources).
debian_mirror() {
  local uri
  uri=$(grep -hs '^URIs:' /etc/apt/sources.list.d/*.sources | awk '{print $2}' | grep -v security | head -n1)
  [ -n "$uri" ] || uri=$(grep -hs '^deb ' /etc/apt/sources.list | awk '{print $2}' | head -n1)
  echo "${uri:-http://deb.debian.org/debian}"
}

base_images() {
  if "${P[@]}" image exists localhost/debian:12 && "${P[@]}" image exists localhost/debian:12-slim; then
    return 0
  fi
  local root
  root=$(mktemp -d)
  log "debootstrap bookworm from $(debian_mirror)"
  debootstrap --variant=minbase bookworm "$root" "$(debian_mirror)" >/dev/null
  tar -C "$root" -c . | "${P[@]}" import - localhost/debian:12 >/dev/null
  # -slim, like Debian's own: no documentation, manual pages, locales or package lists.
  rm -rf "$root"/usr/share/{doc,man,info,locale}/* "$root"/var/lib/apt/lists/* "$root"/var/cache/apt/*
  tar -C "$root" -c . | "${P[@]}" import - localhost/debian:12-slim >/dev/null
  rm -rf "$root"
}
