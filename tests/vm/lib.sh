# Shared by tests/vm/run.sh and tests/vm/bench.sh: tools, the bridge binary, kernel cache,
# initramfs, and booting the VM on a share directory. Source it from the repository root.
# Caches: .cache/vm/ (kernel .deb contents, initramfs; gitignored). Per-run files: target/vm/.
#
# The guest runs the host's own (glibc, dynamically linked) can-bridge build: the initramfs carries
# the shared libraries it links, copied from the host at their absolute paths. A static musl build
# would compile the bridge's whole dependency tree a second time (about 4 min of a cold CI run).

VM_CACHE=${VM_CACHE:-$PWD/.cache/vm}
VM_TIMEOUT=${VM_TIMEOUT:-240}

vm_say() { printf 'vm: %s\n' "$*"; }
vm_fail() { printf 'vm: FAIL: %s\n' "$*" >&2; exit 1; }

vm_check_tools() {
  local missing=()
  for t in qemu-system-x86_64 cpio gzip dpkg-deb apt-get timeout ldd strip; do
    command -v "$t" >/dev/null 2>&1 || missing+=("$t")
  done
  [ -x /bin/busybox ] || missing+=("busybox-static")
  [ ${#missing[@]} -eq 0 ] || vm_fail "missing tools: ${missing[*]} (run scripts/setup.sh test)"
}

# Copies host binary $1 into share directory $2 as bin/NAME, without debug info (the guest reads it
# over 9p under TCG), and records the shared libraries it needs for vm_initramfs in VM_LIBS.
vm_stage_binary() {
  local bin=$1 share=$2 name
  name=$(basename "$bin")
  mkdir -p "$share/bin"
  strip --strip-debug -o "$share/bin/$name" "$bin" || vm_fail "cannot copy $bin into the VM share"
  # ldd prints "libX => /path (addr)" and "/lib64/ld-linux... (addr)"; take every absolute path.
  local libs
  libs=$(ldd "$bin" 2>/dev/null | grep -o '/[^ ]*' | sort -u) || true
  VM_LIBS=()
  local lib
  for lib in $libs; do VM_LIBS+=("$lib"); done
}

# Downloads (once) the Debian kernel and the modules the VM needs; sets VM_KERNEL and VM_MODULES.
vm_kernel() {
  local dir
  dir=$(ls -d "$VM_CACHE"/kernel-* 2>/dev/null | head -n1 || true)
  if [ -z "$dir" ] || [ ! -f "$dir/vmlinuz" ]; then
    local pkg
    pkg=$(apt-cache depends linux-image-amd64 2>/dev/null | awk '/Depends: linux-image-[0-9]/{print $2; exit}')
    if [ -z "$pkg" ]; then
      vm_say "apt lists are empty: apt-get update"
      local sudo=""; [ "$(id -u)" -eq 0 ] || sudo=sudo
      $sudo apt-get update -qq >/dev/null 2>&1 || true
      pkg=$(apt-cache depends linux-image-amd64 2>/dev/null | awk '/Depends: linux-image-[0-9]/{print $2; exit}')
    fi
    [ -n "$pkg" ] || vm_fail "cannot find the Debian kernel package (apt-cache depends linux-image-amd64)"
    dir="$VM_CACHE/kernel-$pkg"
    local tmp="$VM_CACHE/download.$$"
    rm -rf "$tmp" && mkdir -p "$tmp"
    vm_say "downloading $pkg (cached in ${dir#$PWD/})"
    (cd "$tmp" && apt-get download "$pkg" >/dev/null 2>&1) || { rm -rf "$tmp"; vm_fail "apt-get download $pkg failed"; }
    local deb
    deb=$(ls "$tmp"/*.deb | head -n1)
    local wanted
    wanted=$(dpkg-deb -c "$deb" | awk '{print $6}' | grep -E '^\./boot/vmlinuz-|/kernel/(net/can/|drivers/net/can/(vcan|dev/can-dev)|drivers/virtio/|net/9p/|fs/9p/|fs/netfs/|fs/fscache/).*\.ko(\.xz)?$' || true)
    [ -n "$wanted" ] || { rm -rf "$tmp"; vm_fail "$pkg has no vmlinuz/CAN modules"; }
    mkdir -p "$tmp/x"
    # shellcheck disable=SC2086
    dpkg-deb --fsys-tarfile "$deb" | tar -x -C "$tmp/x" $wanted || { rm -rf "$tmp"; vm_fail "extracting $pkg failed"; }
    mkdir -p "$tmp/out/modules"
    cp "$tmp"/x/boot/vmlinuz-* "$tmp/out/vmlinuz"
    find "$tmp/x" -name '*.ko' -exec cp {} "$tmp/out/modules/" \;
    find "$tmp/x" -name '*.ko.xz' -exec sh -c 'xz -dc "$1" > "$2/$(basename "$1" .xz)"' _ {} "$tmp/out/modules" \;
    rm -rf "$dir" && mv "$tmp/out" "$dir" && rm -rf "$tmp"
  fi
  VM_KERNEL="$dir/vmlinuz"
  VM_MODULES="$dir/modules"
}

# Builds (once per init script + module set + runtime libraries) the initramfs; sets VM_INITRD.
# Call vm_stage_binary first: the libraries in VM_LIBS go into the image at their host paths.
vm_initramfs() {
  local key
  key=$( (cat tests/vm/init; ls "$VM_MODULES"; md5sum /bin/busybox "${VM_LIBS[@]}") | md5sum | cut -c1-12)
  VM_INITRD="$VM_CACHE/initramfs-$key.cpio.gz"
  [ -f "$VM_INITRD" ] && return 0
  local root="$VM_CACHE/initramfs.$$"
  rm -rf "$root" && mkdir -p "$root/bin" "$root/lib/modules"
  cp /bin/busybox "$root/bin/busybox"
  cp "$VM_MODULES"/*.ko "$root/lib/modules/"
  cp tests/vm/init "$root/init" && chmod 755 "$root/init"
  local lib
  for lib in "${VM_LIBS[@]}"; do
    mkdir -p "$root$(dirname "$lib")"
    cp -L "$lib" "$root$lib" || vm_fail "cannot copy the runtime library $lib into the initramfs"
  done
  (cd "$root" && find . | cpio -o -H newc --quiet | gzip -1) > "$VM_INITRD.tmp"
  mv "$VM_INITRD.tmp" "$VM_INITRD" && rm -rf "$root"
}

# Boots the VM on share directory $1 (which holds guest.sh); serial output to $1/console.log.
# Returns the guest script's exit code (99 if the VM never reported one).
vm_boot() {
  local share=$1 mem=${VM_MEM:-512}
  rm -f "$share/guest.rc"
  timeout --foreground -k 5 "$VM_TIMEOUT" qemu-system-x86_64 -accel tcg -m "$mem" -smp "${VM_SMP:-1}" -nodefaults \
    -display none -serial stdio -net none -no-reboot \
    -kernel "$VM_KERNEL" -initrd "$VM_INITRD" \
    -virtfs "local,path=$share,mount_tag=host,security_model=none" \
    -device isa-debug-exit,iobase=0xf4,iosize=0x04 \
    -append 'console=ttyS0 quiet panic=-1' > "$share/console.log" 2>&1 || true
  if [ -f "$share/guest.rc" ]; then
    return "$(cat "$share/guest.rc")"
  fi
  return 99
}
