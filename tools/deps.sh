#!/bin/sh
# tools/deps.sh WHAT PACKAGE... -- installs those of rayd's Debian packages
# that are missing (make deps, make test-deps, make bench-deps, make lint).
#
# dpkg-query says which packages are installed, which costs nothing; only when
# some are missing does the script run `apt-get update`, once, and then
# `apt-get install` of the missing ones alone, with sudo when not root.  WHAT
# names the make target in the message.
#
# Installing a package must not start a service on the host.  nginx and
# redis-server are here for the tests, which run their own on loopback; nginx's Debian package
# starts the system's nginx on port 80 when it is configured on a systemd
# host.  So while apt-get runs, /usr/sbin/policy-rc.d answers 101 ("action
# not allowed"), which invoke-rc.d and deb-systemd-invoke obey, and a freshly
# installed nginx is then disabled, so the next boot does not start it either.
# A policy-rc.d already there (Docker images ship one) is left as it is.
set -eu

what=$1
shift
missing=
for p in "$@"; do
    dpkg-query -W -f='${Status}\n' "$p" 2>/dev/null | grep -q '^install ok installed' ||
        missing="$missing $p"
done
[ -n "$missing" ] || exit 0

echo "$what: installing$missing"
sudo=
[ "$(id -u)" = 0 ] || sudo=sudo

policy=/usr/sbin/policy-rc.d
ours=
if [ ! -e "$policy" ]; then
    printf '#!/bin/sh\n# rayd tools/deps.sh: no service starts while packages install\nexit 101\n' |
        $sudo tee "$policy" >/dev/null
    $sudo chmod 755 "$policy"
    ours=1
fi
unpolicy() { if [ -n "$ours" ]; then $sudo rm -f "$policy"; fi; }
trap unpolicy EXIT
trap 'exit 130' INT TERM

# Another apt-get may hold dpkg's lock (a second clone's make, the host's
# own updates): wait for it, up to 10 minutes, rather than fail at once.
wait_lock="-o DPkg::Lock::Timeout=600"
# shellcheck disable=SC2086 # an option and its value
$sudo apt-get $wait_lock update -qq
# shellcheck disable=SC2086 # one word a package
$sudo env DEBIAN_FRONTEND=noninteractive apt-get $wait_lock install -y -qq --no-install-recommends $missing

for svc in nginx redis-server; do
    case " $missing " in
    *" $svc "*)
        if command -v systemctl >/dev/null 2>&1; then
            $sudo systemctl disable --quiet "$svc.service" 2>/dev/null || true
        fi
        echo "$what: $svc installed for the tests only; its service is not started nor enabled"
        ;;
    esac
done
