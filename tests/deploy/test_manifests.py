"""deploy/: the Kubernetes manifests loaded (Debian's python3-yaml) and checked for the fields
a cluster needs and that must agree with each other and with raycastd (names, labels, ports,
probes on /v1/health, resources, ReadWriteMany, every RAYCASTD_ key an option raycastd knows);
kubeconform too when it is installed. deploy/nginx.conf is checked for what docs/deploy.md
promises and, when nginx is installed, by `nginx -t` on the loopback form the scale test runs.

Run by CTest as deploy_manifests, with RAYCASTD_BINARY naming the server binary."""

import os
import re
import shutil
import subprocess
import sys
import tempfile
import unittest
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
K8S = ROOT / "deploy" / "k8s"
sys.path.insert(0, str(ROOT / "tests" / "scale"))
import nginx_local  # noqa: E402  (tests/scale/nginx_local.py)

try:
    import yaml
except ImportError:
    yaml = None


def memory_bytes(quantity: str) -> int:
    units = {"Ki": 1 << 10, "Mi": 1 << 20, "Gi": 1 << 30, "Ti": 1 << 40}
    m = re.fullmatch(r"(\d+)(Ki|Mi|Gi|Ti)?", quantity)
    assert m, f"not a memory quantity: {quantity}"
    return int(m.group(1)) * units.get(m.group(2), 1)


@unittest.skipIf(yaml is None, "PyYAML is not installed (Debian: apt-get install python3-yaml)")
class Manifests(unittest.TestCase):
    @classmethod
    def setUpClass(cls) -> None:
        cls.docs = {}
        for path in sorted(K8S.glob("*.yaml")):
            if path.name == "kustomization.yaml":
                continue
            for doc in yaml.safe_load_all(path.read_text()):
                for field in ("apiVersion", "kind", "metadata"):
                    assert field in doc, f"{path.name}: no {field}"
                cls.docs[doc["kind"]] = doc

    def test_every_kind_is_there_and_listed(self) -> None:
        self.assertEqual(
            set(self.docs),
            {
                "Deployment",
                "Service",
                "HorizontalPodAutoscaler",
                "PersistentVolumeClaim",
                "ConfigMap",
            },
        )
        listed = yaml.safe_load((K8S / "kustomization.yaml").read_text())["resources"]
        on_disk = {p.name for p in K8S.glob("*.yaml")} - {"kustomization.yaml"}
        self.assertEqual(set(listed), on_disk)

    def test_deployment(self) -> None:
        d = self.docs["Deployment"]
        self.assertEqual(d["apiVersion"], "apps/v1")
        spec = d["spec"]
        pod = spec["template"]
        labels = pod["metadata"]["labels"]
        for k, v in spec["selector"]["matchLabels"].items():
            self.assertEqual(labels.get(k), v, "the selector must match the pod's labels")
        self.assertTrue(pod["spec"]["securityContext"]["runAsNonRoot"])
        (c,) = pod["spec"]["containers"]
        self.assertRegex(c["image"], r":(?!latest$)[\w.-]+$", "a pinned image tag")
        ports = {p["name"]: p["containerPort"] for p in c["ports"]}
        self.assertEqual(ports.get("http"), 8080)
        for probe in ("readinessProbe", "livenessProbe"):
            get = c[probe]["httpGet"]
            self.assertEqual(get["path"], "/v1/health", probe)
            self.assertIn(get["port"], ports, probe)
        res = c["resources"]
        for field in ("cpu", "memory"):
            self.assertIn(field, res["requests"])
        self.assertIn("memory", res["limits"])
        self.assertLessEqual(
            memory_bytes(res["requests"]["memory"]), memory_bytes(res["limits"]["memory"])
        )
        # The scene, body, answer and job-image budgets together fit the limit, with room for
        # the process itself (each is set: the defaults are sized for a machine, not a pod).
        config = self.docs["ConfigMap"]["data"]
        budgets = (
            "RAYCASTD_MEMORY_BUDGET_MB",
            "RAYCASTD_BODY_BUDGET_MB",
            "RAYCASTD_ANSWER_BUDGET_MB",
            "RAYCASTD_JOB_BUDGET_MB",
        )
        budget = sum(int(config[k]) for k in budgets) << 20
        self.assertLess(budget + (64 << 20), memory_bytes(res["limits"]["memory"]))
        self.assertEqual(
            c["envFrom"][0]["configMapRef"]["name"], self.docs["ConfigMap"]["metadata"]["name"]
        )
        self.assertEqual(c["env"][0]["name"], "RAYCASTD_TOKEN")
        self.assertIn("secretKeyRef", c["env"][0]["valueFrom"])
        mounts = {m["mountPath"]: m["name"] for m in c["volumeMounts"]}
        self.assertEqual(set(mounts), {"/data", "/models"})
        volumes = {v["name"]: v for v in pod["spec"]["volumes"]}
        self.assertEqual(
            volumes[mounts["/data"]]["persistentVolumeClaim"]["claimName"],
            self.docs["PersistentVolumeClaim"]["metadata"]["name"],
        )
        self.assertEqual(config["RAYCASTD_DATA_DIR"], "/data")
        self.assertEqual(config["RAYCASTD_SCENE_ROOT"], "/models")
        self.assertEqual(int(config["RAYCASTD_PORT"]), ports["http"])

    def test_service_hpa_pvc(self) -> None:
        pod = self.docs["Deployment"]["spec"]["template"]
        svc = self.docs["Service"]["spec"]
        for k, v in svc["selector"].items():
            self.assertEqual(pod["metadata"]["labels"].get(k), v)
        port_names = {p["name"] for p in pod["spec"]["containers"][0]["ports"]}
        for p in svc["ports"]:
            self.assertIn(p["targetPort"], port_names)
        hpa = self.docs["HorizontalPodAutoscaler"]
        self.assertEqual(hpa["apiVersion"], "autoscaling/v2")
        target = hpa["spec"]["scaleTargetRef"]
        self.assertEqual(target["kind"], "Deployment")
        self.assertEqual(target["name"], self.docs["Deployment"]["metadata"]["name"])
        self.assertLessEqual(hpa["spec"]["minReplicas"], hpa["spec"]["maxReplicas"])
        self.assertEqual(hpa["spec"]["metrics"][0]["resource"]["name"], "cpu")
        pvc = self.docs["PersistentVolumeClaim"]["spec"]
        self.assertEqual(pvc["accessModes"], ["ReadWriteMany"])
        memory_bytes(pvc["resources"]["requests"]["storage"])

    def test_every_config_key_is_an_option(self) -> None:
        binary = os.environ.get("RAYCASTD_BINARY")
        if not binary:
            self.skipTest("needs RAYCASTD_BINARY")
        help_text = subprocess.run([binary, "--help"], capture_output=True, text=True).stdout
        env = dict(self.docs["ConfigMap"]["data"])
        for key, value in env.items():
            self.assertIsInstance(value, str, f"{key}: ConfigMap values are strings")
            flag = "--" + key[len("RAYCASTD_") :].lower().replace("_", "-")
            self.assertIn(flag + " ", help_text, f"{key}: raycastd has no {flag}")
        # And raycastd accepts them all, as the container would get them (then asks for help).
        r = subprocess.run(
            [binary, "--help"], env=dict(os.environ, **env), capture_output=True, text=True
        )
        self.assertEqual(r.returncode, 0, r.stderr)

    def test_kubeconform_if_installed(self) -> None:
        kubeconform = shutil.which("kubeconform")
        if not kubeconform:
            self.skipTest("kubeconform is not installed (not packaged for Debian 12)")
        files = [str(p) for p in K8S.glob("*.yaml") if p.name != "kustomization.yaml"]
        r = subprocess.run(
            [kubeconform, "-strict", "-summary", *files], capture_output=True, text=True
        )
        self.assertEqual(r.returncode, 0, r.stdout + r.stderr)


class NginxConf(unittest.TestCase):
    def setUp(self) -> None:
        self.text = (ROOT / "deploy" / "nginx.conf").read_text()

    def test_what_docs_deploy_promises(self) -> None:
        self.assertRegex(self.text, r"hash \$scene_id consistent;")
        self.assertRegex(self.text, r'map "\$uri[^"]*" \$scene_id')
        self.assertIn("proxy_next_upstream error timeout", self.text)
        self.assertIn("non_idempotent", self.text)
        self.assertIn("proxy_set_header X-Request-Id", self.text)

    def test_nginx_accepts_it(self) -> None:
        nginx = shutil.which("nginx") or (
            "/usr/sbin/nginx" if os.path.exists("/usr/sbin/nginx") else None
        )
        if not nginx:
            self.skipTest("nginx is not installed (Debian: apt-get install nginx)")
        with tempfile.TemporaryDirectory() as work:
            conf = Path(work) / "nginx.conf"
            conf.write_text(nginx_local.local_conf(Path(work), 18080, [18081, 18082, 18083]))
            r = subprocess.run(
                [nginx, "-t", "-p", work, "-e", f"{work}/logs/error.log", "-c", str(conf)],
                capture_output=True,
                text=True,
            )
            self.assertEqual(r.returncode, 0, r.stderr)
            self.assertIn("test is successful", r.stderr)


if __name__ == "__main__":
    unittest.main()
