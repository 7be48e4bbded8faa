#!/usr/bin/env python3
"""scripts/gaze-score.py on hand-made cases with known answers: AUC with and
without ties, CC, the share at the maximum, |mean curvature| against a
sphere's 1/r, and the fixation-weighted and plain errors of a flat remesh."""
import importlib.util
import math
import os
import subprocess
import sys
import tempfile
import unittest

try:
    import numpy as np
except ImportError:  # ctest reads 77 as "skipped" (SKIP_RETURN_CODE in tests/CMakeLists.txt)
    print("gaze_score_test: numpy is not installed; skipped")
    sys.exit(77)

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
SCRIPT = os.path.join(ROOT, "scripts", "gaze-score.py")
spec = importlib.util.spec_from_file_location("gaze_score", SCRIPT)
gs = importlib.util.module_from_spec(spec)
spec.loader.exec_module(gs)


def write_ply(path, positions, faces, extra=()):
    """extra: (name, ply type, numpy dtype, values) vertex properties after x y z."""
    n = len(positions)
    head = ["ply", "format binary_little_endian 1.0", f"element vertex {n}",
            "property float x", "property float y", "property float z"]
    head += [f"property {t} {name}" for name, t, _, _ in extra]
    head += [f"element face {len(faces)}", "property list uchar int vertex_indices", "end_header"]
    dt = np.dtype([("x", "<f4"), ("y", "<f4"), ("z", "<f4")] + [(name, d) for name, _, d, _ in extra])
    v = np.zeros(n, dt)
    for k, axis in enumerate("xyz"):
        v[axis] = positions[:, k]
    for name, _, _, values in extra:
        v[name] = values
    f = np.zeros(len(faces), np.dtype([("n", "u1"), ("i", "<i4", 3)]))
    f["n"] = 3
    f["i"] = faces
    with open(path, "wb") as out:
        out.write(("\n".join(head) + "\n").encode())
        out.write(v.tobytes())
        out.write(f.tobytes())


class GazeScore(unittest.TestCase):
    def test_auc_known_values(self):
        self.assertAlmostEqual(gs.auc([1, 2, 3, 4], [0, 0, 1, 1]), 1.0)
        self.assertAlmostEqual(gs.auc([4, 3, 2, 1], [0, 0, 1, 1]), 0.0)
        # Positives 0.35 and 0.8 against negatives 0.1 and 0.4: 3 of 4 pairs ordered.
        self.assertAlmostEqual(gs.auc([0.1, 0.4, 0.35, 0.8], [0, 0, 1, 1]), 0.75)
        # Ties count half: a constant field is chance.
        self.assertAlmostEqual(gs.auc([1, 1, 1, 1, 1], [0, 1, 0, 1, 0]), 0.5)
        # One tie across the classes: (1 + 0.5) / 2.
        self.assertAlmostEqual(gs.auc([1, 2, 2], [0, 0, 1]), 0.75)

    def test_cc_and_share(self):
        self.assertAlmostEqual(gs.cc([1, 2, 3], [2, 4, 6]), 1.0)
        self.assertAlmostEqual(gs.cc([1, 2, 3], [3, 2, 1]), -1.0)
        self.assertAlmostEqual(gs.share_at_max([0.2, 1, 1, 0.5]), 0.5)

    def test_mean_curvature_of_a_sphere_is_one_over_r(self):
        # An octahedron refined four times and pushed onto a sphere of radius 2.
        p = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]], float)
        f = np.array([[0, 2, 4], [2, 1, 4], [1, 3, 4], [3, 0, 4], [2, 0, 5], [1, 2, 5], [3, 1, 5], [0, 3, 5]])
        for _ in range(4):
            mids, nf = {}, []
            pts = list(p)
            def mid(a, b):
                key = (min(a, b), max(a, b))
                if key not in mids:
                    mids[key] = len(pts)
                    pts.append((pts[a] + pts[b]) / 2)
                return mids[key]
            for a, b, c in f:
                ab, bc, ca = mid(a, b), mid(b, c), mid(c, a)
                nf += [[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]
            p, f = np.array(pts), np.array(nf)
        p = 2 * p / np.linalg.norm(p, axis=1)[:, None]
        h = gs.mean_curvature(p, f)
        self.assertLess(abs(np.median(h) - 0.5), 0.02)

    def test_weighted_and_plain_error_of_a_flat_remesh(self):
        with tempfile.TemporaryDirectory() as tmp:
            # The remesh: the square [-1, 1]^2 at z = 0, two triangles.
            square = np.array([[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]], float)
            write_ply(os.path.join(tmp, "remesh.ply"), square, np.array([[0, 1, 2], [0, 2, 3]]))
            # The "gaze mesh": points above the square and one beside it, 1 from its edge.
            q = np.array([[0, 0, 0.1], [0.5, 0, 0.3], [0, 0.5, 0.2], [2, 0, 0]], float)
            fixation = np.array([3, 1, 0, 0], np.float32)
            write_ply(os.path.join(tmp, "gaze.ply"), q, np.array([[0, 1, 2], [1, 2, 3]]),
                      [("fixation", "float", "<f4", fixation), ("top5", "uchar", "u1", [1, 0, 0, 0])])
            out = subprocess.run([sys.executable, SCRIPT, "error", os.path.join(tmp, "gaze.ply"),
                                  os.path.join(tmp, "remesh.ply")], capture_output=True, text=True, check=True)
            words = out.stdout.split()
            diag = np.linalg.norm(q.max(0) - q.min(0))
            self.assertAlmostEqual(float(words[1]), (3 * 0.1 + 1 * 0.3) / 4 / diag, places=5)
            self.assertAlmostEqual(float(words[3]), (0.1 + 0.3 + 0.2 + 1.0) / 4 / diag, places=5)
            # The field score reads a field written in the gaze mesh's vertex order.
            write_ply(os.path.join(tmp, "field.ply"), q, np.array([[0, 1, 2], [1, 2, 3]]),
                      [("saliency", "float", "<f4", [0.9, 0.5, 0.2, 0.2])])
            out = subprocess.run([sys.executable, SCRIPT, "field", os.path.join(tmp, "gaze.ply"),
                                  os.path.join(tmp, "field.ply")], capture_output=True, text=True, check=True)
            row = out.stdout.strip().splitlines()[-1].split("|")
            self.assertAlmostEqual(float(row[3]), 1.0)  # the one top5 vertex has the highest value
            self.assertEqual(row[5].strip(), "25.0%")

    def test_fixation_field_ranks_the_looked_at_vertices(self):
        # Not looked at: 0; looked at: 0.2 + 0.8 x rank among them, ties sharing the mean rank.
        field = gs.fixation_field([0, 5, 1, 0, 9, 5])
        np.testing.assert_allclose(field, [0, 0.2 + 0.8 * 1.5 / 3, 0.2, 0, 1.0, 0.2 + 0.8 * 1.5 / 3])
        np.testing.assert_allclose(gs.fixation_field([0, 0, 3]), [0, 0, 1])
        with tempfile.TemporaryDirectory() as tmp:
            q = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]], float)
            faces = np.array([[0, 1, 2], [1, 3, 2]])
            write_ply(os.path.join(tmp, "gaze.ply"), q, faces,
                      [("fixation", "float", "<f4", [0, 2, 1, 0]), ("top5", "uchar", "u1", [0, 1, 0, 0])])
            subprocess.run([sys.executable, SCRIPT, "fixation-field", os.path.join(tmp, "gaze.ply"),
                            os.path.join(tmp, "fix.ply")], check=True)
            v, f = gs.read_ply(os.path.join(tmp, "fix.ply"))
            np.testing.assert_allclose(gs.positions(v), q)
            np.testing.assert_array_equal(f, faces)
            np.testing.assert_allclose(v["saliency"], [0, 1, 0.2, 0], atol=1e-6)

    def test_blend_runs_from_the_fields_rank_to_the_fixation(self):
        fixation = [0, 5, 1, 0, 9, 5]
        field = [0.3, 0.1, 0.1, 0.9, 0.5, 0.2]
        # Ranks of the field over n - 1 = 5, the two 0.1s sharing their mean rank (0.5).
        np.testing.assert_allclose(gs.rank01(field), [3 / 5, 0.1, 0.1, 1.0, 4 / 5, 2 / 5])
        np.testing.assert_allclose(gs.blend(fixation, field, 0.0), gs.rank01(field))
        np.testing.assert_allclose(gs.blend(fixation, field, 1.0), gs.fixation_field(fixation))
        np.testing.assert_allclose(gs.blend(fixation, field, 0.25),
                                   0.25 * gs.fixation_field(fixation) + 0.75 * gs.rank01(field))
        with tempfile.TemporaryDirectory() as tmp:
            q = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]], float)
            faces = np.array([[0, 1, 2], [1, 3, 2]])
            write_ply(os.path.join(tmp, "gaze.ply"), q, faces,
                      [("fixation", "float", "<f4", [0, 2, 1, 0]), ("top5", "uchar", "u1", [0, 1, 0, 0])])
            write_ply(os.path.join(tmp, "field.ply"), q, faces, [("saliency", "float", "<f4", [0.4, 0.1, 0.2, 0.3])])
            out = subprocess.run([sys.executable, SCRIPT, "blend", os.path.join(tmp, "gaze.ply"),
                                  os.path.join(tmp, "field.ply"), "0.5", os.path.join(tmp, "b.ply")],
                                 capture_output=True, text=True, check=True)
            v, _ = gs.read_ply(os.path.join(tmp, "b.ply"))
            # fixation field [0, 1, 0.2, 0]; the field's ranks [1, 0, 1/3, 2/3].
            np.testing.assert_allclose(v["saliency"], [0.5, 0.5, (0.2 + 1 / 3) / 2, 1 / 3], atol=1e-6)
            self.assertIn("AUC", out.stdout)
            bad = subprocess.run([sys.executable, SCRIPT, "blend", os.path.join(tmp, "gaze.ply"),
                                  os.path.join(tmp, "field.ply"), "1.5", os.path.join(tmp, "b.ply")],
                                 capture_output=True, text=True)
            self.assertNotEqual(bad.returncode, 0)
            self.assertIn("not in [0, 1]", bad.stderr)

    def test_point_triangle_distance_against_sampling(self):
        rng = np.random.default_rng(7)
        a, b, c = rng.normal(size=(3, 200, 3))
        q = 2 * rng.normal(size=(200, 3))
        exact = gs.point_triangle_distance(q, a, b, c)
        # Dense barycentric samples bound the distance from above, and come close.
        u, v = np.meshgrid(np.linspace(0, 1, 201), np.linspace(0, 1, 201))
        keep = u + v <= 1
        u, v = u[keep], v[keep]
        for i in range(0, 200, 20):
            pts = a[i] + u[:, None] * (b[i] - a[i]) + v[:, None] * (c[i] - a[i])
            sampled = np.min(np.linalg.norm(pts - q[i], axis=1))
            self.assertLessEqual(exact[i], sampled + 1e-12)
            self.assertLess(sampled - exact[i], 0.02 * max(1.0, np.linalg.norm(b[i] - a[i])))


if __name__ == "__main__":
    unittest.main()
