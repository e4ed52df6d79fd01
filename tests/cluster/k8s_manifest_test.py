#!/usr/bin/python3
"""The Kubernetes manifest (deploy/k8s/render.sh + sequence.yaml.in), offline:
1. rendered manifests pass the schema check (k8s_schema_check.py: python3-kubernetes models
   plus the API server's Job rules), and broken ones fail it, naming the field;
2. render.sh refuses bad options and plans with one line naming what is wrong;
3. the pods' commands, run the way Kubernetes would run them (one per completion index,
   $(JOB_COMPLETION_INDEX) expanded from the env the manifest defines, then the merge Job's
   init container and container), drive the sequence through to the merged output;
   the init container waits while a shard is missing.
Exit 77 (skip) without python3-yaml / python3-kubernetes.
    tests/cluster/k8s_manifest_test.py
HDRD_BIN: the program the pods run (default: the stand-in beside this file).
"""
import copy
import os
import re
import subprocess
import sys
import tempfile

try:
    import yaml
    import kubernetes  # noqa: F401  (the schema check imports its models)
except ImportError as e:
    print(f"SKIP: {e.name} missing (Debian packages python3-yaml python3-kubernetes; "
          "scripts/install-cluster-test-deps.sh installs them)")
    sys.exit(77)

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import k8s_schema_check  # noqa: E402
ROOT = os.path.dirname(os.path.dirname(HERE))
RENDER = os.path.join(ROOT, "deploy/k8s/render.sh")
SCHEMA = os.path.join(HERE, "k8s_schema_check.py")
PROGRAM = os.environ.get("HDRD_BIN", os.path.join(HERE, "stand_in_hdrd.sh"))
failures = []


def check(what, ok, detail=""):
    print(("ok: " if ok else "FAIL: ") + what + (f" ({detail})" if detail and not ok else ""))
    if not ok:
        failures.append(what)


def run(cmd, **kw):
    return subprocess.run(cmd, capture_output=True, text=True, timeout=60, **kw)


def render(plan, outbase, *options):
    return run([RENDER, plan, outbase, *options])


def schema_problems(text):
    """The schema check's problems for a manifest, in this process (importing the models
    once takes seconds; the command-line form is run once, in main)."""
    return [e for doc in yaml.safe_load_all(text) if doc is not None for e in k8s_schema_check.check_document(doc)]


def expand(arg, env):
    """Kubernetes' $(VAR) expansion in command and args (pkg/kubelet/container expansion)."""
    return re.sub(r"\$\((\w+)\)", lambda m: env.get(m.group(1), m.group(0)), arg)


def container_env(container, pod_annotations):
    env = {}
    for e in container.get("env") or []:
        if "value" in e:
            env[e["name"]] = e["value"]
        else:
            path = e["valueFrom"]["fieldRef"]["fieldPath"]
            m = re.fullmatch(r"metadata\.annotations\['([^']+)'\]", path)
            env[e["name"]] = pod_annotations[m.group(1)]
    return env


def run_container(container, annotations, timeout=60):
    env = container_env(container, annotations)
    cmd = [expand(a, env) for a in container["command"]]
    return subprocess.run(cmd, env={**os.environ, **env}, capture_output=True, text=True, timeout=timeout)


def main():
    tmp = tempfile.mkdtemp(prefix="hdrd-k8s-test-")
    work = os.path.join(tmp, "vol")
    os.makedirs(work)
    n = 4
    plan = os.path.join(work, "Shot_01.json")
    r = run([PROGRAM, "sequence", "plan", "--shards", str(n), "-o", plan, "--frames", "10"])
    check("the program writes a plan", r.returncode == 0, r.stderr.strip())
    outbase = os.path.join(work, "out/shot")
    os.makedirs(os.path.dirname(outbase))

    # 1. The schema check passes the rendered manifests and fails broken ones.
    variants = {
        "defaults": ["--image", "hdrd:test", "--mount", work],
        "with a claim": ["--image", "example.org/hdrd@sha256:" + "a" * 64, "--mount", work, "--create-claim", "200Gi",
                         "--storage-class", "nfs-client", "--parallelism", "2", "--backoff-limit", "0",
                         "--cpu", "1500m", "--memory", "3.5Gi", "--name", "s1"],
    }
    manifests = {}
    for label, options in variants.items():
        r = render(plan, outbase, *options)
        check(f"render.sh ({label}) succeeds", r.returncode == 0, r.stderr.strip())
        manifests[label] = r.stdout
        problems = schema_problems(r.stdout)
        check(f"the manifest ({label}) passes the schema check", not problems, "; ".join(problems))
    path = os.path.join(tmp, "manifest.yaml")
    with open(path, "w") as f:
        f.write(manifests["defaults"])
    s = run([sys.executable, SCHEMA, path])
    check("k8s_schema_check.py passes it on the command line", s.returncode == 0 and not s.stdout, s.stdout.strip())
    docs = list(yaml.safe_load_all(manifests["defaults"]))
    shards, merge = docs
    kinds = [d["kind"] for d in yaml.safe_load_all(manifests["with a claim"])]
    check("--create-claim adds a PersistentVolumeClaim", kinds == ["PersistentVolumeClaim", "Job", "Job"], str(kinds))
    breakages = {
        "an unknown field": (lambda d: d[0]["spec"].update(completionz=3), "spec.completionz: unknown field"),
        "a wrong type": (lambda d: d[0]["spec"].update(completions="4"), "spec.completions: expected int"),
        "a missing required field": (lambda d: d[0]["spec"]["template"]["spec"]["containers"][0].pop("name"),
                                     "containers[0].name: required field missing"),
        "restartPolicy Always": (lambda d: d[0]["spec"]["template"]["spec"].update(restartPolicy="Always"),
                                 "restartPolicy: 'Always'"),
        "Indexed without completions": (lambda d: d[0]["spec"].pop("completions"), "spec.completions: an Indexed Job"),
        "a mount of no volume": (lambda d: d[1]["spec"]["template"]["spec"]["containers"][0]["volumeMounts"][0]
                                 .update(name="other"), "no volume 'other'"),
        "a bad downward API path": (lambda d: d[0]["spec"]["template"]["spec"]["containers"][0]["env"][0]["valueFrom"]
                                    ["fieldRef"].update(fieldPath="metadata.index"), "not served by the downward API"),
        "an unknown kind": (lambda d: d[1].update(kind="CronJobb"), "not a kind this check knows"),
    }
    for label, (breakage, expected) in breakages.items():
        broken = copy.deepcopy(docs)
        breakage(broken)
        problems = schema_problems(yaml.safe_dump_all(broken))
        check(f"the schema check rejects {label}", any(expected in e for e in problems), "; ".join(problems))

    # What the manifest says, read back.
    pod = shards["spec"]["template"]["spec"]
    check("the shards are an Indexed Job with completions = N",
          shards["spec"]["completionMode"] == "Indexed" and shards["spec"]["completions"] == n)
    check("each shard pod runs `sequence run PLAN --shard $(JOB_COMPLETION_INDEX)`",
          pod["containers"][0]["command"][1:] == ["sequence", "run", plan, "--shard", "$(JOB_COMPLETION_INDEX)"])
    claims = {v["persistentVolumeClaim"]["claimName"] for d in docs for v in d["spec"]["template"]["spec"]["volumes"]}
    check("every pod mounts the one claim", claims == {"hdrd-work"}, str(claims))

    # Without --image, the image scripts/make-image.sh tags: hdrd:VERSION of the source tree.
    with open(os.path.join(os.path.dirname(RENDER), "../../CMakeLists.txt")) as f:
        version = re.search(r"^project\(hdrd VERSION ([0-9.]+)", f.read(), re.M).group(1)
    r = render(plan, outbase, "--mount", work)
    images = {c["image"] for d in yaml.safe_load_all(r.stdout) for c in d["spec"]["template"]["spec"]["containers"]}
    check("render.sh defaults to the image make-image.sh tags", r.returncode == 0 and images == {f"hdrd:{version}"},
          r.stderr.strip() or str(images))

    # 2. render.sh refuses what cannot work.
    refusals = {
        "a plan outside the mount": ([plan, outbase, "--image", "i", "--mount", "/elsewhere"], "is not under the volume mount"),
        "an OUTBASE outside the mount": ([plan, "/tmp/x", "--image", "i", "--mount", work], "OUTBASE /tmp/x is not under"),
        "a bad name": ([plan, outbase, "--image", "i", "--mount", work, "--name", "Shot_1"], "--name Shot_1"),
        "a name too long for the pods' hostnames": ([plan, outbase, "--image", "i", "--mount", work, "--name", "a" * 60],
                                                    "at most 54 characters"),
        "a bad quantity": ([plan, outbase, "--image", "i", "--mount", work, "--memory", "2GB"], "--memory 2GB"),
        "a bad count": ([plan, outbase, "--image", "i", "--mount", work, "--parallelism", "0"], "--parallelism 0"),
        "a missing plan": ([plan + ".nope", outbase, "--image", "i"], "no such file"),
        "an unknown option": ([plan, outbase, "--image", "i", "--colour", "x"], "unknown option --colour"),
    }
    for label, (args, expected) in refusals.items():
        r = run([RENDER, *args])
        lines = r.stderr.strip().splitlines()
        check(f"render.sh refuses {label} with one line",
              r.returncode == 1 and len(lines) == 1 and expected in lines[0] and not r.stdout, r.stderr.strip())

    # 3. Run the pods as Kubernetes would, with the program under test.
    r = render(plan, outbase, "--image", "hdrd:test", "--mount", work, "--hdrd", PROGRAM)
    shards, merge = yaml.safe_load_all(r.stdout)
    shard_container = shards["spec"]["template"]["spec"]["containers"][0]
    init = merge["spec"]["template"]["spec"]["initContainers"][0]
    merge_container = merge["spec"]["template"]["spec"]["containers"][0]
    for i in range(n - 1):
        p = run_container(shard_container, {"batch.kubernetes.io/job-completion-index": str(i)})
        check(f"shard pod {i} succeeds", p.returncode == 0, p.stderr.strip())
    try:
        run_container(init, {}, timeout=1.5)
        check("the merge's init container waits while a shard is missing", False, "it exited")
    except subprocess.TimeoutExpired:
        check("the merge's init container waits while a shard is missing", True)
    p = run_container(shard_container, {"batch.kubernetes.io/job-completion-index": str(n - 1)})
    check(f"shard pod {n - 1} succeeds", p.returncode == 0, p.stderr.strip())
    p = run_container(init, {}, timeout=20)
    check("the init container lets the merge start once every shard is done", p.returncode == 0, p.stderr.strip())
    p = run_container(merge_container, {})
    check("the merge pod succeeds", p.returncode == 0, p.stderr.strip())
    check("the merged video exists", os.path.getsize(outbase + ".mp4") > 0)
    if PROGRAM == os.path.join(HERE, "stand_in_hdrd.sh"):
        with open(outbase + ".mp4") as f:
            check("it holds every frame once, in order", f.read() == "".join(f"frame {i}\n" for i in range(10)))

    subprocess.run(["rm", "-rf", tmp])
    print(f"{len(failures)} check(s) failed" if failures else "all checks passed")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
