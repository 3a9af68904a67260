"""/v1/explain?format=markdown as students read it: no words inside math, the tutorial's notation."""

from __future__ import annotations

import base64
import json
import re
import unittest

from support import REPO, TRIANGLE, TUTORIAL, ServerTestCase

#: $$…$$ or $…$ (an escaped \$ is text).
MATH = re.compile(r"(?<!\\)\$\$(.+?)(?<!\\)\$\$|(?<!\\)\$(.+?)(?<!\\)\$", re.S)
#: What may hold letters inside math: a command, and the arguments of \text, \begin, \end.
ALLOWED = re.compile(r"\\(?:text|begin|end|mathrm|operatorname)\{[^}]*\}|\\[A-Za-z]+")


def words_in_math(md: str) -> list[str]:
    """Runs of 3+ ASCII letters inside math that are neither LaTeX commands nor \\text{}:
    GitHub and KaTeX set those as products of italic variables ("discriminant")."""
    words = []
    for m in MATH.finditer(md):
        body = ALLOWED.sub(" ", m.group(1) or m.group(2))
        words += re.findall(r"[A-Za-z]{3,}", body)
    return words


class CheckerTest(unittest.TestCase):
    def test_checker(self) -> None:
        self.assertEqual(words_in_math("$discriminant B^2-4AC = 16$"), ["discriminant"])
        self.assertEqual(
            words_in_math("$t = 8 or t = 12$"), []
        )  # "or": two letters, still prose-ish
        self.assertEqual(
            words_in_math("$$\\begin{pmatrix}1\\\\2\\end{pmatrix}$$ $\\sqrt{3} \\text{ miss }$"), []
        )
        self.assertEqual(words_in_math("costs \\$5, $abc$"), ["abc"])


class ExplainMarkdownTest(ServerTestCase):
    def markdown(self, scene: dict, ray: dict) -> str:
        md = self.client.explain(scene, ray, markdown=True)
        self.assertEqual(words_in_math(md), [], md)
        self.assertEqual(md.count("$$") % 2, 0, md)
        for m in MATH.finditer(md):
            tex = m.group(1) or m.group(2)
            if m.group(2) is not None:
                self.assertNotIn("\\\\", tex, "row breaks only in display math: " + tex)
            self.assertEqual(tex.count("{"), tex.count("}"), tex)
            # KaTeX refuses a double superscript such as 10^{-6}^2.
            self.assertIsNone(re.search(r"\^(\{[^{}]*\}|\w)\^", tex), tex)
        return md

    def test_tutorial_question_1(self) -> None:
        md = self.markdown(TUTORIAL, {"origin": [0, 0, 0], "direction": [0, 0, 1]})
        self.assertIn("9 \\pm \\sqrt{3}", md)
        self.assertIn("$t = 8$ or $t = 12$", md)
        self.assertIn("**sphere 3**", md)
        self.assertNotIn("$discriminant", md)
        self.assertNotIn(" or t = ", md.replace("$t = 8$ or $t = 12$", ""))
        # The JSON steps are the engine's plain text, unchanged.
        ex = self.client.explain(TUTORIAL, {"origin": [0, 0, 0], "direction": [0, 0, 1]})
        self.assertIn("t^2 - 20t + 96 = 0", ex["objects"][0]["steps"])

    def test_triangle_question_3(self) -> None:
        md = self.markdown(TRIANGLE, {"origin": [0.5, 0.5, 0], "direction": [0, 0, 1]})
        self.assertIn("ac \\times ab", md)
        self.assertIn("\\langle n, x\\rangle = \\langle n, a\\rangle", md)
        self.assertNotIn("<n,", md)
        miss = self.markdown(TRIANGLE, {"origin": [1.5, 1.5, 0], "direction": [0, 0, 1]})
        self.assertIn("outside the triangle", miss)
        self.markdown(TRIANGLE, {"origin": [0, 0, 0], "direction": [1, 0, 0]})  # parallel

    def test_other_scenes_and_misses(self) -> None:
        q2 = json.loads((REPO / "tests/golden/scenes/tutorial_q2.json").read_text())
        self.markdown(q2, {"origin": [0, 0, 0], "direction": [0, 0, 1]})
        self.markdown(TUTORIAL, {"origin": [0, 0, 0], "direction": [0, 0, -1], "tmax": 5})
        self.markdown(TUTORIAL, {"origin": [0.1, 0.25, -3.5], "direction": [0.01, 0.02, 1]})
        tiny = {"objects": [{"type": "sphere", "center": [0.123456789, 0, 40], "radius": 1e-6}]}
        self.markdown(tiny, {"origin": [0.123456789, 0, 0], "direction": [0, 0, 1]})
        obj = "v 0 0 5\nv 2 0 5\nv 0 2 5\nv 2 2 5\nf 1 2 3\nf 2 4 3\n"
        mesh = {
            "objects": [
                {
                    "type": "mesh",
                    "format": "obj",
                    "name": "quad $1",
                    "data_base64": base64.b64encode(obj.encode()).decode(),
                }
            ]
        }
        md = self.markdown(mesh, {"origin": [0.5, 0.5, 0], "direction": [0, 0, 1]})
        self.assertIn("quad \\$1", md)


if __name__ == "__main__":
    unittest.main()
