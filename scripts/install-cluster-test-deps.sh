#!/usr/bin/env bash
# Installs what the cluster tests (tests/cluster, docs/cluster.md) need and the build does
# not: Slurm and munge for the one-node test cluster (scripts/slurm-local.sh), jq, and
# python3-kubernetes + python3-yaml for the offline Kubernetes schema check. Test-only:
# scripts/install-deps.sh does not install these. Debian 12 packages; needs root (or sudo);
# installs only what is missing. The packages' maintainer scripts try to start slurmctld,
# slurmd and munge; without an init system (containers) that is refused, which is fine:
# the tests start their own daemons.
set -euo pipefail
packages=(slurm-wlm munge jq python3-kubernetes python3-yaml)
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q '^install ok installed' || missing+=("$p")
done
[ ${#missing[@]} -eq 0 ] && exit 0
echo "install-cluster-test-deps: installing ${missing[*]}" >&2
sudo=""
[ "$(id -u)" -eq 0 ] || sudo=sudo
export DEBIAN_FRONTEND=noninteractive
$sudo apt-get update -qq
$sudo apt-get install -y -qq --no-install-recommends "${missing[@]}" >&2
