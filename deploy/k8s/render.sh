#!/usr/bin/env bash
# Writes the Kubernetes manifest for an `hdrd sequence plan` to stdout: an Indexed Job with a
# pod per shard and a merge Job, on a shared ReadWriteMany claim (deploy/k8s/sequence.yaml.in,
# docs/cluster.md). Apply it with `kubectl apply -f -`.
#
#   deploy/k8s/render.sh PLAN.json OUTBASE [--image IMAGE] [options]
#
#   --image IMAGE          the container image with hdrd in it (default hdrd:VERSION, the image
#                          scripts/make-image.sh builds from this source tree's version)
#   --name NAME            the Jobs' name prefix (NAME-shards, NAME-merge); default: the
#                          plan's file name, lower-cased, [a-z0-9-] only
#   --mount PATH           where the claim is mounted in every pod (default /work); the plan,
#                          its work_dir and OUTBASE must lie under it
#   --plan-path PATH       the plan's path inside the pods (default: PLAN.json's own path,
#                          for a plan read from the claim mounted at the same path here)
#   --claim NAME           the PersistentVolumeClaim (default hdrd-work)
#   --create-claim SIZE    also emit that claim (ReadWriteMany, SIZE e.g. 200Gi)
#   --storage-class CLASS  its storage class (default: the cluster's default)
#   --parallelism K        at most K shard pods at once (default: all N)
#   --backoff-limit B      failed shard pods retried, over all shards (default: N)
#   --cpu Q --memory Q     each pod's requests (default 1 and 2Gi)
#   --merge-deadline-s S   the merge Job's activeDeadlineSeconds, its wait for the shards
#                          included (default 86400)
#   --ttl-s S              finished Jobs are deleted after S seconds (default 86400)
#   --hdrd PATH            the hdrd program in the image (default hdrd, on its PATH)
# Exit status 1 with one line on stderr naming what is wrong.
set -euo pipefail
prog=render.sh
here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
# shellcheck source=../lib/plan.sh
. "$here/../lib/plan.sh"

die() { echo "$prog: $*" >&2; exit 1; }

# A YAML double-quoted scalar (JSON string syntax); values with control characters are refused.
quote() {
  local v=$1
  [[ "$v" != *[[:cntrl:]]* ]] || die "$2: control characters are not allowed"
  v=${v//\\/\\\\}
  v=${v//\"/\\\"}
  printf '"%s"' "$v"
}
check_uint() { [[ "$2" =~ ^[0-9]+$ ]] && (( 10#$2 >= $3 )) || die "$1 $2: expected an integer >= $3"; }
check_quantity() {  # a Kubernetes resource quantity, e.g. 500m, 2, 1.5Gi
  [[ "$2" =~ ^[0-9]+(\.[0-9]+)?(m|k|M|G|T|P|E|Ki|Mi|Gi|Ti|Pi|Ei)?$ ]] || die "$1 $2: expected a quantity like 500m, 2 or 4Gi"
}
check_dns_label() {  # RFC 1123 label, as Kubernetes requires for names that become hostnames
  [[ "$2" =~ ^[a-z0-9]([-a-z0-9]*[a-z0-9])?$ ]] || die "$1 $2: expected lower-case letters, digits and '-', starting and ending with a letter or digit"
}
under() { case "$2" in "$1"|"$1"/*) return 0 ;; *) return 1 ;; esac; }
absolute() { case "$2" in /*) ;; *) die "$1 $2: expected an absolute path" ;; esac; }

[ $# -ge 2 ] || die "usage: $prog PLAN.json OUTBASE [--image IMAGE] [options] (see the header of $0)"
plan=$1 outbase=$2
shift 2
image="" name="" mount=/work plan_path="" claim=hdrd-work create_claim="" storage_class=""
parallelism="" backoff_limit="" cpu=1 memory=2Gi merge_deadline_s=86400 ttl_s=86400 hdrd=hdrd
while [ $# -gt 0 ]; do
  [ $# -ge 2 ] || die "$1: needs a value"
  case "$1" in
    --image) image=$2 ;;
    --name) name=$2 ;;
    --mount) mount=${2%/} ;;
    --plan-path) plan_path=$2 ;;
    --claim) claim=$2 ;;
    --create-claim) create_claim=$2 ;;
    --storage-class) storage_class=$2 ;;
    --parallelism) parallelism=$2 ;;
    --backoff-limit) backoff_limit=$2 ;;
    --cpu) cpu=$2 ;;
    --memory) memory=$2 ;;
    --merge-deadline-s) merge_deadline_s=$2 ;;
    --ttl-s) ttl_s=$2 ;;
    --hdrd) hdrd=$2 ;;
    *) die "unknown option $1" ;;
  esac
  shift 2
done

plan_read "$plan" || exit 1
if [ -z "$image" ]; then  # the image scripts/make-image.sh tags: hdrd:VERSION of this source tree
  version=$(sed -n 's/^project(hdrd VERSION \([0-9.]*\).*/\1/p' "$here/../../CMakeLists.txt" 2>/dev/null || true)
  [ -n "$version" ] || die "--image IMAGE is required (the image with hdrd in it; no source tree version for hdrd:VERSION)"
  image=hdrd:$version
fi
[[ "$image" =~ ^[^[:space:]]+$ ]] || die "--image $image: no spaces allowed"
if [ -z "$name" ]; then
  name=$(basename "$plan" .json | tr 'A-Z_.' 'a-z--' | tr -cd 'a-z0-9-' | sed 's/^-*//; s/-*$//')
  [ -n "$name" ] || name=hdrd-sequence
fi
check_dns_label --name "$name"
# The shard pods' hostnames are NAME-shards-I: an RFC 1123 label, at most 63 characters.
last_index=$((PLAN_SHARDS - 1))
max_name=$((63 - ${#last_index} - 8))
(( ${#name} <= max_name )) || die "--name $name: at most $max_name characters for $PLAN_SHARDS shards (pod hostnames NAME-shards-I are DNS labels of up to 63)"
check_dns_label --claim "$claim"
absolute --mount "$mount"
[ -n "$plan_path" ] || plan_path=$PLAN_PATH
absolute --plan-path "$plan_path"
case "$outbase" in /*) ;; *) outbase=$PWD/$outbase ;; esac
for p in "plan $plan_path:$plan_path" "work_dir $PLAN_WORK_DIR:$PLAN_WORK_DIR" "OUTBASE $outbase:$outbase"; do
  under "$mount" "${p#*:}" || die "${p%%:*} is not under the volume mount $mount: the pods would not share it (--mount, --plan-path)"
done
parallelism=${parallelism:-$PLAN_SHARDS}
backoff_limit=${backoff_limit:-$PLAN_SHARDS}
check_uint --parallelism "$parallelism" 1
check_uint --backoff-limit "$backoff_limit" 0
check_uint --merge-deadline-s "$merge_deadline_s" 1
check_uint --ttl-s "$ttl_s" 0
check_quantity --cpu "$cpu"
check_quantity --memory "$memory"

pvc=""
if [ -n "$create_claim" ]; then
  check_quantity --create-claim "$create_claim"
  pvc="apiVersion: v1
kind: PersistentVolumeClaim
metadata:
  name: $claim
  labels:
    app.kubernetes.io/name: hdrd
    app.kubernetes.io/instance: $name
spec:
  accessModes: [ReadWriteMany]
  resources:
    requests:
      storage: $(quote "$create_claim" --create-claim)
"
  if [ -n "$storage_class" ]; then
    check_dns_label --storage-class "$storage_class"
    pvc+="  storageClassName: $storage_class
"
  fi
  pvc+="---
"
fi

shopt -u patsub_replacement 2>/dev/null || true
manifest=$(<"$here/sequence.yaml.in")
subst() { manifest=${manifest//"@$1@"/"$2"}; }
subst PVC_DOCUMENT "$pvc"
subst NAME "$name"
subst SHARDS "$PLAN_SHARDS"
subst PARALLELISM "$parallelism"
subst BACKOFF_LIMIT "$backoff_limit"
subst MERGE_DEADLINE_S "$merge_deadline_s"
subst TTL_S "$ttl_s"
subst CLAIM "$claim"
subst IMAGE "$(quote "$image" --image)"
subst HDRD "$(quote "$hdrd" --hdrd)"
subst PLAN "$(quote "$plan_path" --plan-path)"
subst OUTBASE "$(quote "$outbase" OUTBASE)"
subst WORK_DIR "$(quote "$PLAN_WORK_DIR" work_dir)"
subst MOUNT "$(quote "$mount" --mount)"
subst CPU "$(quote "$cpu" --cpu)"
subst MEMORY "$(quote "$memory" --memory)"
if [[ "$manifest" =~ @[A-Z][A-Z_]*@ ]]; then die "internal: template field ${BASH_REMATCH[0]} was left unfilled"; fi
printf '%s\n' "$manifest"
