"""The Dockerfile, checked without a Docker engine: its build stage installs exactly
scripts/setup.sh's build_packages, its runtime stage exactly the packages that own the shared
libraries the built raycastd links (ldd + dpkg -S), and the rules of a production image hold
(multi-stage, slim runtime, non-root user, health check, volumes, apt lists removed, every
RAYCASTD_ variable an option raycastd knows). hadolint runs too when it is installed (Debian 12
does not package it).

Run by CTest as deploy_dockerfile, with RAYCASTD_BINARY naming the server binary."""

import os
import re
import shutil
import subprocess
import unittest
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
# In every Debian image (essential): not named by the runtime stage.
ESSENTIAL = {"libc6"}
SANITIZER_RUNTIME = re.compile(r"^lib(asan|ubsan|tsan|lsan)\d+$")


def setup_build_packages() -> list:
    """build_packages=( ... ) of scripts/setup.sh, comments dropped."""
    text = (ROOT / "scripts" / "setup.sh").read_text()
    m = re.search(r"^build_packages=\((.*?)^\)", text, re.S | re.M)
    assert m, "scripts/setup.sh has no build_packages=( ... ) array"
    words = []
    for line in m.group(1).splitlines():
        words += line.split("#", 1)[0].split()
    return words


def instructions(path: Path) -> list:
    """(INSTRUCTION, arguments) pairs, continuation lines joined and comments dropped."""
    out, current = [], ""
    for line in path.read_text().splitlines():
        stripped = line.strip()
        if not current and (not stripped or stripped.startswith("#")):
            continue
        if stripped.startswith("#"):
            continue  # a comment inside a continued instruction
        current += " " + stripped
        if current.endswith("\\"):
            current = current[:-1]
            continue
        keyword, _, args = current.strip().partition(" ")
        out.append((keyword.upper(), args.strip()))
        current = ""
    return out


def stages(path: Path) -> list:
    """[(FROM arguments, [(INSTRUCTION, arguments), ...]), ...]"""
    result = []
    for keyword, args in instructions(path):
        if keyword == "FROM":
            result.append((args, []))
        else:
            result[-1][1].append((keyword, args))
    return result


def apt_installs(stage_instructions: list) -> list:
    """The packages of every `apt-get install` in a stage's RUN lines."""
    packages = []
    for keyword, args in stage_instructions:
        if keyword != "RUN":
            continue
        for command in args.split("&&"):
            words = command.split()
            if "apt-get" in words and "install" in words:
                after = words[words.index("install") + 1 :]
                packages += [w for w in after if not w.startswith("-")]
    return packages


def linked_packages(binary: str) -> set:
    """The Debian packages owning the shared libraries `binary` links."""
    ldd = subprocess.run(["ldd", binary], capture_output=True, text=True, check=True).stdout
    owners = set()
    for line in ldd.splitlines():
        m = re.search(r"=> (/\S+)", line)
        if not m:
            continue
        lib = m.group(1)
        # usrmerge: dpkg may know a library under /lib or /usr/lib, or by its target.
        for candidate in (lib, os.path.realpath(lib), lib.replace("/usr/lib/", "/lib/", 1)):
            r = subprocess.run(["dpkg", "-S", candidate], capture_output=True, text=True)
            if r.returncode == 0:
                owners.add(r.stdout.split(":", 1)[0])
                break
        else:
            raise AssertionError(f"no Debian package owns {lib}")
    return owners


class Dockerfile(unittest.TestCase):
    def setUp(self) -> None:
        self.stages = stages(ROOT / "Dockerfile")

    def test_two_stages_on_debian_12(self) -> None:
        self.assertEqual(len(self.stages), 2)
        self.assertEqual(self.stages[0][0], "debian:12 AS build")
        self.assertEqual(self.stages[1][0], "debian:12-slim AS runtime")

    def test_build_stage_installs_setup_sh_build_packages(self) -> None:
        installed = apt_installs(self.stages[0][1])
        expected = setup_build_packages()
        self.assertEqual(sorted(installed), sorted(expected))
        self.assertEqual(len(installed), len(set(installed)), "a package named twice")

    def test_runtime_stage_installs_what_the_binary_links(self) -> None:
        binary = os.environ.get("RAYCASTD_BINARY")
        if not binary or not shutil.which("ldd") or not shutil.which("dpkg"):
            self.skipTest("needs RAYCASTD_BINARY, ldd and dpkg")
        installed = set(apt_installs(self.stages[1][1]))
        # A sanitizer build (the asan preset) links its runtimes, which the image's release
        # build does not.
        linked = {p for p in linked_packages(binary) if not SANITIZER_RUNTIME.match(p)}
        self.assertEqual(installed, linked - ESSENTIAL)
        self.assertFalse(
            any(p.endswith("-dev") for p in installed), "a -dev package in the runtime image"
        )

    def test_production_rules(self) -> None:
        runtime = self.stages[1][1]
        keywords = [k for k, _ in runtime]
        for k, args in runtime:
            if k == "RUN" and "apt-get install" in args:
                self.assertIn("--no-install-recommends", args)
                self.assertIn("rm -rf /var/lib/apt/lists/*", args)
        users = [a for k, a in runtime if k == "USER"]
        self.assertEqual(len(users), 1)
        self.assertNotIn(users[0], ("root", "0"))
        self.assertLess(keywords.index("USER"), keywords.index("ENTRYPOINT"))
        health = [a for k, a in runtime if k == "HEALTHCHECK"]
        self.assertEqual(len(health), 1)
        self.assertIn('CMD ["raycastd", "--health-check"]', health[0])
        volumes = " ".join(a for k, a in runtime if k == "VOLUME")
        self.assertIn('"/data"', volumes)
        self.assertIn('"/models"', volumes)
        self.assertIn("COPY", keywords)
        self.assertTrue(
            any(k == "COPY" and a.startswith("--from=build") for k, a in runtime),
            "the runtime stage copies the binary from the build stage",
        )

    def test_every_variable_is_an_option(self) -> None:
        binary = os.environ.get("RAYCASTD_BINARY")
        if not binary:
            self.skipTest("needs RAYCASTD_BINARY")
        help_text = subprocess.run(
            [binary, "--help"], capture_output=True, text=True, check=True
        ).stdout
        env = " ".join(a for k, a in self.stages[1][1] if k == "ENV")
        names = re.findall(r"(RAYCASTD_[A-Z_]+)=", env)
        self.assertIn("RAYCASTD_DATA_DIR", names)
        for name in names:
            if name == "RAYCASTD_WEB_ROOT":  # read by the preview page's route, not a flag
                continue
            flag = "--" + name[len("RAYCASTD_") :].lower().replace("_", "-")
            self.assertIn(flag + " ", help_text, f"{name}: raycastd has no {flag}")

    def test_hadolint_if_installed(self) -> None:
        hadolint = shutil.which("hadolint")
        if not hadolint:
            self.skipTest("hadolint is not installed (Debian 12 has no package for it)")
        r = subprocess.run([hadolint, str(ROOT / "Dockerfile")], capture_output=True, text=True)
        self.assertEqual(r.returncode, 0, r.stdout + r.stderr)

    def test_the_context_leaves_out_build_trees(self) -> None:
        ignored = (ROOT / ".dockerignore").read_text().split()
        self.assertIn("build/", ignored)
        self.assertIn(".git/", ignored)


if __name__ == "__main__":
    unittest.main()
