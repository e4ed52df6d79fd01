#!/usr/bin/python3
"""Checks Kubernetes manifests offline against the API schema (docs/cluster.md, "Checked how").

    k8s_schema_check.py MANIFEST.yaml...

`kubectl apply --dry-run=client --validate=true` needs an API server even in client mode
(discovery for the REST mapping, /openapi/v2 for the schema), so this does the same checks
without one. The schema is Debian 12's python3-kubernetes 22.6 (generated from the
Kubernetes 1.22 OpenAPI spec): every document's apiVersion/kind must be a known model, every
field a field of its model (unknown ones are what `--validate=strict` rejects), every value of
its declared type, and every required field present. On top of the schema, the rules of the
API server's Job and PodSpec validation that a manifest can break (k8s.io/kubernetes
pkg/apis/batch/validation, pkg/apis/core/validation): RFC 1123 names, restartPolicy Never or
OnFailure in a Job, completionMode Indexed with completions set, unique container names,
volume mounts that name a volume, env fieldRefs to a path the downward API serves.
Prints one line per problem ("FILE: doc N (Kind name): path: what"); exit status 1 if any.
"""
import re
import sys

import kubernetes.client.models as models
import yaml
from kubernetes.client import Configuration

KINDS = {
    ("batch/v1", "Job"): "V1Job",
    ("v1", "PersistentVolumeClaim"): "V1PersistentVolumeClaim",
    ("v1", "ConfigMap"): "V1ConfigMap",
}
DNS_LABEL = re.compile(r"^[a-z0-9]([-a-z0-9]*[a-z0-9])?$")
DNS_SUBDOMAIN = re.compile(r"^[a-z0-9]([-a-z0-9]*[a-z0-9])?(\.[a-z0-9]([-a-z0-9]*[a-z0-9])?)*$")
ENV_NAME = re.compile(r"^[-._a-zA-Z][-._a-zA-Z0-9]*$")
# The downward API's env fieldRef paths (pkg/apis/core/validation validEnvDownwardAPIFieldPathExpressions).
FIELD_PATHS = re.compile(r"^(metadata\.(name|namespace|uid)|metadata\.(labels|annotations)\['[^']+'\]|"
                         r"spec\.(nodeName|serviceAccountName)|status\.(hostIP|hostIPs|podIP|podIPs))$")
CONFIG = Configuration()
CONFIG.client_side_validation = True


class Missing(Exception):
    pass


def model_class(type_name):
    return getattr(models, type_name, None)


def check_value(value, type_name, path, errors):
    """Checks one value against a python3-kubernetes type string: str, int, bool, float,
    object, datetime, list[T], dict(str, T) or a model class name."""
    if value is None:
        return
    m = re.fullmatch(r"list\[(.+)\]", type_name)
    if m:
        if not isinstance(value, list):
            errors.append(f"{path}: expected a list, got {type(value).__name__}")
            return
        for i, item in enumerate(value):
            check_value(item, m.group(1), f"{path}[{i}]", errors)
        return
    m = re.fullmatch(r"dict\(str, (.+)\)", type_name)
    if m:
        if not isinstance(value, dict):
            errors.append(f"{path}: expected a map, got {type(value).__name__}")
            return
        for k, v in value.items():
            if not isinstance(k, str):
                errors.append(f"{path}: key {k!r} is not a string")
            check_value(v, m.group(1), f"{path}.{k}", errors)
        return
    primitives = {"str": (str,), "int": (int,), "bool": (bool,), "float": (int, float), "datetime": (str,), "date": (str,)}
    if type_name in primitives:
        ok = isinstance(value, primitives[type_name]) and not (type_name in ("int", "float") and isinstance(value, bool))
        if not ok:
            errors.append(f"{path}: expected {type_name}, got {type(value).__name__} {value!r}")
        return
    if type_name == "object":
        return
    cls = model_class(type_name)
    if cls is None:
        errors.append(f"{path}: the schema has no type {type_name}")
        return
    check_model(value, cls, path, errors)


def check_model(value, cls, path, errors):
    if not isinstance(value, dict):
        errors.append(f"{path}: expected an object ({cls.__name__}), got {type(value).__name__}")
        return
    by_json = {j: py for py, j in cls.attribute_map.items()}
    given = {}
    for key, v in value.items():
        if key not in by_json:
            errors.append(f"{path}.{key}: unknown field ({cls.__name__} has no field {key!r})")
            continue
        py = by_json[key]
        check_value(v, cls.openapi_types[py], f"{path}.{key}", errors)
        given[py] = v
    # Required fields: the generated setters raise on None for them. Construct the model
    # with what was given (nested values as placeholders) until nothing more is missing.
    args = {py: (v if isinstance(v, (str, int, float, bool)) else object()) for py, v in given.items()}
    for _ in range(len(cls.attribute_map) + 1):
        try:
            cls(local_vars_configuration=CONFIG, **args)
            return
        except ValueError as e:
            m = re.search(r"Invalid value for `(\w+)`, must not be `None`", str(e))
            if not m or m.group(1) in args:
                errors.append(f"{path}: {e}")
                return
            errors.append(f"{path}.{cls.attribute_map[m.group(1)]}: required field missing")
            args[m.group(1)] = object()


def check_name(name, path, errors, label=False):
    pattern, limit, what = (DNS_LABEL, 63, "an RFC 1123 label") if label else (DNS_SUBDOMAIN, 253, "an RFC 1123 subdomain")
    if not isinstance(name, str) or not pattern.match(name) or len(name) > limit:
        errors.append(f"{path}: {name!r} is not {what} of at most {limit} characters")


def check_pod_spec(spec, path, errors):
    if not isinstance(spec, dict):
        return
    volumes = {v.get("name") for v in spec.get("volumes") or [] if isinstance(v, dict)}
    names = set()
    for group in ("initContainers", "containers"):
        for i, c in enumerate(spec.get(group) or []):
            if not isinstance(c, dict):
                continue
            cpath = f"{path}.{group}[{i}]"
            check_name(c.get("name"), f"{cpath}.name", errors, label=True)
            if c.get("name") in names:
                errors.append(f"{cpath}.name: {c.get('name')!r} is used twice")
            names.add(c.get("name"))
            for j, m in enumerate(c.get("volumeMounts") or []):
                if isinstance(m, dict) and m.get("name") not in volumes:
                    errors.append(f"{cpath}.volumeMounts[{j}].name: no volume {m.get('name')!r} in the pod")
                if isinstance(m, dict) and not str(m.get("mountPath", "")).startswith("/"):
                    errors.append(f"{cpath}.volumeMounts[{j}].mountPath: must be absolute")
            for j, e in enumerate(c.get("env") or []):
                if not isinstance(e, dict):
                    continue
                if not ENV_NAME.match(str(e.get("name", ""))):
                    errors.append(f"{cpath}.env[{j}].name: {e.get('name')!r} is not a valid variable name")
                ref = ((e.get("valueFrom") or {}).get("fieldRef") or {}).get("fieldPath")
                if ref is not None and not FIELD_PATHS.match(ref):
                    errors.append(f"{cpath}.env[{j}].valueFrom.fieldRef.fieldPath: {ref!r} is not served by the downward API")


def check_job(doc, errors):
    spec = doc.get("spec") or {}
    check_name((doc.get("metadata") or {}).get("name"), "metadata.name", errors, label=True)
    pod = ((spec.get("template") or {}).get("spec")) or {}
    if pod.get("restartPolicy") not in ("Never", "OnFailure"):
        errors.append(f"spec.template.spec.restartPolicy: {pod.get('restartPolicy')!r}: a Job's pods need Never or OnFailure")
    mode = spec.get("completionMode", "NonIndexed")
    if mode not in ("NonIndexed", "Indexed"):
        errors.append(f"spec.completionMode: {mode!r}: expected NonIndexed or Indexed")
    if mode == "Indexed":
        if not isinstance(spec.get("completions"), int) or spec["completions"] < 1:
            errors.append("spec.completions: an Indexed Job needs completions >= 1")
        elif spec["completions"] > 100000:
            errors.append("spec.completions: at most 100000 for an Indexed Job")
    for key in ("completions", "parallelism", "backoffLimit", "ttlSecondsAfterFinished"):
        if isinstance(spec.get(key), int) and spec[key] < 0:
            errors.append(f"spec.{key}: must be >= 0")
    if isinstance(spec.get("activeDeadlineSeconds"), int) and spec["activeDeadlineSeconds"] < 1:
        errors.append("spec.activeDeadlineSeconds: must be >= 1")
    check_pod_spec(pod, "spec.template.spec", errors)


def check_document(doc):
    errors = []
    key = (doc.get("apiVersion"), doc.get("kind"))
    if key not in KINDS:
        return [f"apiVersion {key[0]!r} kind {key[1]!r}: not a kind this check knows ({', '.join(f'{a} {k}' for a, k in KINDS)})"]
    check_model(doc, model_class(KINDS[key]), "", errors)
    errors = [e.lstrip(".") for e in errors]
    if key == ("batch/v1", "Job"):
        check_job(doc, errors)
    else:
        check_name((doc.get("metadata") or {}).get("name"), "metadata.name", errors)
    return errors


def main(paths):
    problems = 0
    for path in paths:
        try:
            with open(path, encoding="utf-8") as f:
                docs = [d for d in yaml.safe_load_all(f) if d is not None]
        except (OSError, yaml.YAMLError) as e:
            print(f"{path}: not readable YAML: {e}".replace("\n", " "))
            problems += 1
            continue
        if not docs:
            print(f"{path}: no documents")
            problems += 1
        for n, doc in enumerate(docs, 1):
            if not isinstance(doc, dict):
                print(f"{path}: doc {n}: not a mapping")
                problems += 1
                continue
            what = f"{doc.get('kind')} {(doc.get('metadata') or {}).get('name')}"
            for e in check_document(doc):
                print(f"{path}: doc {n} ({what}): {e}")
                problems += 1
    return 1 if problems else 0


if __name__ == "__main__":
    if len(sys.argv) < 2:
        sys.exit("usage: k8s_schema_check.py MANIFEST.yaml...")
    sys.exit(main(sys.argv[1:]))
