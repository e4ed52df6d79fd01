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
# shellcheck source=scripts/lib/apt-missing.sh
source "$(dirname "${BASH_SOURCE[0]}")/lib/apt-missing.sh"
apt_install_missing install-cluster-test-deps "${packages[@]}"
