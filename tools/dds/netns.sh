#!/usr/bin/env bash
# Runs CMD inside a fresh, throwaway network namespace whose only interface is a loopback with
# multicast enabled (and a 224.0.0.0/4 route on it), and exits with CMD's status.
#
# Why: DDS discovery multicasts (SPDP to 239.255.0.1) on every multicast-capable interface. Tests
# and probes of `autoact record` must not send DDS traffic off the machine, so anything that starts
# DDS (RustDDS, Cyclone) runs through this script. Processes started by one CMD share the
# namespace and find each other; nothing inside can reach the outside network. Multicast on `lo`
# is needed for a participant to reach its own readers in the same process (RustDDS finds no
# usable self-locator without it; measured in the ROS/MCAP feasibility notes, §3).
#
#   tools/dds/netns.sh CMD [ARG...]      e.g. tools/dds/netns.sh sh -c 'a & b; wait'
#
# Needs root (or CAP_SYS_ADMIN) for `unshare -n`, and iproute2.
set -euo pipefail
[ $# -ge 1 ] || { echo "usage: $0 CMD [ARG...]" >&2; exit 2; }
exec unshare -n sh -c '
  set -e
  ip link set lo up
  ip link set lo multicast on
  ip route add 224.0.0.0/4 dev lo
  exec "$@"' netns "$@"
