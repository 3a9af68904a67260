"""The array queries over the binary endpoints: NumPy arrays and plain lists, in chunks."""

from __future__ import annotations

import math
import unittest

from support import TRIANGLE, TUTORIAL, ServerTestCase, numpy

from raycastd import MISS_ID, BadRequest, Client

T3 = 7.267949192431123  # 9 − √3: the tutorial's first hit


class ListPathTest(ServerTestCase):
    """Without NumPy: nested lists in, nested lists of the same shape out."""

    def setUp(self) -> None:
        self.lists = Client(self.server.url, arrays="list", chunk_rays=2)

    def tearDown(self) -> None:
        self.lists.close()

    def test_cast_rays_shapes_and_misses(self) -> None:
        rays = [[[0, 0, 0, 0, 0, 1]], [[0, 0, 0, 0, 0, -1]], [[0, 0, 20, 0, 0, -1]]]
        ans = self.lists.cast_rays(TUTORIAL, rays)
        self.assertEqual(ans["t_hit"], [[T3], [math.inf], [8.0]])
        self.assertEqual(ans["geometry_ids"], [[2], [MISS_ID], [0]])
        self.assertEqual(ans["primitive_ids"], [[0], [MISS_ID], [0]])
        self.assertEqual(ans["primitive_uvs"][0], [[0.0, 0.0]])
        self.assertAlmostEqual(ans["primitive_normals"][0][0][2], -math.sqrt(3) / 2, places=12)
        one = self.lists.cast_rays(TUTORIAL, [0, 0, 0, 0, 0, 1])  # a single ray: scalars
        self.assertEqual(one["t_hit"], T3)

    def test_origins_directions_tmin_tmax(self) -> None:
        ans = self.lists.cast_rays(
            TUTORIAL,
            origins=[[0, 0, 0]] * 3,
            directions=[[0, 0, 1]] * 3,
            tmin=[0, 7.5, 0],
            tmax=[math.inf, math.inf, 7],
        )
        self.assertEqual(ans["t_hit"], [T3, 8.0, math.inf])

    def test_occlusion_count_and_list(self) -> None:
        rays = [[0, 0, 0, 0, 0, 1], [0, 0, 0, 0, 0, -1], [0, 0, 0, 0, 0.2, 1]]
        self.assertEqual(self.lists.test_occlusions(TUTORIAL, rays), [True, False, True])
        # (0, 0.2, 1) passes through all three spheres.
        self.assertEqual(self.lists.count_intersections(TUTORIAL, rays), [4, 0, 6])
        every = self.lists.list_intersections(TUTORIAL, rays)
        self.assertEqual(every["ray_splits"], [0, 4, 4, 10])
        self.assertEqual(every["ray_ids"], [0] * 4 + [2] * 6)
        self.assertEqual(every["geometry_ids"][:4], [2, 0, 2, 0])
        self.assertEqual(every["t_hit"][:4], sorted(every["t_hit"][:4]))

    def test_bad_ray_index_counts_across_chunks(self) -> None:
        rays = [[0, 0, 0, 0, 0, 1]] * 5
        rays[3] = [0, 0, 0, 0, 0, 0]
        with self.assertRaises(BadRequest) as cm:
            self.lists.cast_rays(TUTORIAL, rays)  # chunks of 2: the bad ray is the 2nd of chunk 2
        self.assertEqual(cm.exception.code, "invalid_ray")
        self.assertIn("ray 3", cm.exception.message)
        self.assertEqual(cm.exception.path, "/rays/3")

    def test_float32_wire(self) -> None:
        ans = self.lists.cast_rays(
            TUTORIAL, [[0, 0, 0, 0, 0, 1]], dtype="float32", precision="fast"
        )
        self.assertAlmostEqual(ans["t_hit"][0], T3, places=5)
        with self.assertRaises(ValueError):
            self.lists.cast_rays(TUTORIAL, [[0, 0, 0, 0, 0, 1]], dtype="float16")

    def test_points_lists(self) -> None:
        d = self.lists.compute_distance(TUTORIAL, [[0, 0, 0], [0, 0, 10]])
        # The nearest of the three spheres to the eye is sphere 2 at (0, 3, 8), not the first hit
        # along +z (sphere 3): 8.544 − 2 against 9.055 − 2.
        self.assertAlmostEqual(d[0], math.dist((0, 0, 0), (0, 3, 8)) - 2, places=9)
        self.assertEqual(
            self.lists.compute_occupancy(TUTORIAL, [[0, 0, 10], [0, 0, -9]]), [1.0, 0.0]
        )
        sd = self.lists.compute_signed_distance(TUTORIAL, [[0, 0, 10]])
        self.assertLess(sd[0], 0)
        cp = self.lists.compute_closest_points(TRIANGLE, [[0.5, 0.5, 0]])
        self.assertEqual(cp["points"][0], [0.5, 0.5, 5.0])
        self.assertEqual(cp["distances"][0], 5.0)


@unittest.skipIf(numpy is None, "NumPy is not installed (Debian: python3-numpy)")
class NumpyPathTest(ServerTestCase):
    def setUp(self) -> None:
        self.np = Client(self.server.url, arrays="numpy", chunk_rays=1000)

    def tearDown(self) -> None:
        self.np.close()

    def rays(self, dtype: object) -> object:
        """A 2 × 3 grid of rays from the eye, the middle one straight at the spheres."""
        np = numpy
        d = np.array([[[0, 0.1 * i, 1] for i in (-1, 0, 1)], [[0, 0, -1], [1, 0, 0], [0, 0.3, 1]]])
        o = np.zeros_like(d)
        return np.concatenate([o, d], axis=-1).astype(dtype)

    def test_cast_rays_float32_and_float64(self) -> None:
        np = numpy
        for dtype, wire in (
            (np.float32, np.float32),
            (np.float16, np.float32),
            (np.float64, np.float64),
        ):
            ans = self.np.cast_rays(TUTORIAL, self.rays(dtype))
            self.assertEqual(ans["t_hit"].shape, (2, 3))
            self.assertEqual(ans["t_hit"].dtype, wire)
            self.assertEqual(ans["primitive_uvs"].shape, (2, 3, 2))
            self.assertEqual(ans["primitive_normals"].shape, (2, 3, 3))
            self.assertEqual(ans["geometry_ids"].dtype, np.uint32)
            self.assertTrue(np.isinf(ans["t_hit"][1, 0]) and np.isinf(ans["t_hit"][1, 1]))
            self.assertEqual(ans["geometry_ids"][1, 0], MISS_ID)
            self.assertAlmostEqual(float(ans["t_hit"][0, 1]), T3, places=5)
        ints = np.array([[0, 0, 0, 0, 0, 1]], dtype=np.int32)  # integers travel as float64
        self.assertEqual(self.np.cast_rays(TUTORIAL, ints)["t_hit"].dtype, np.float64)
        exact = self.np.cast_rays(TUTORIAL, self.rays(np.float64), precision="exact")
        self.assertEqual(exact["t_hit"][0, 1], T3)

    def test_lists_and_numpy_agree_and_chunks_do_not_matter(self) -> None:
        np = numpy
        rng = np.random.default_rng(3241)
        rays = np.concatenate(
            [rng.normal(0, 0.5, (2500, 3)), rng.normal(0, 1, (2500, 3)) + [0, 0, 2]], axis=1
        )
        whole = self.np.cast_rays(TUTORIAL, rays)
        with Client(self.server.url, arrays="list", chunk_rays=700) as lists:
            parts = lists.cast_rays(TUTORIAL, rays.tolist())
        np.testing.assert_array_equal(whole["t_hit"], np.array(parts["t_hit"]))
        np.testing.assert_array_equal(whole["geometry_ids"], np.array(parts["geometry_ids"]))
        self.assertGreater(int(np.isfinite(whole["t_hit"]).sum()), 100)

    def test_origins_directions_broadcast(self) -> None:
        np = numpy
        dirs = np.array([[0, 0, 1], [0, 0, -1]], dtype=np.float32)
        ans = self.np.cast_rays(TUTORIAL, origins=np.zeros(3, np.float32), directions=dirs)
        self.assertEqual(ans["t_hit"].shape, (2,))
        self.assertTrue(np.isinf(ans["t_hit"][1]))

    def test_occlusion_count_list(self) -> None:
        np = numpy
        rays = self.rays(np.float32)
        occ = self.np.test_occlusions(TUTORIAL, rays)
        self.assertEqual(occ.dtype, np.bool_)
        np.testing.assert_array_equal(occ, [[True, True, True], [False, False, True]])
        counts = self.np.count_intersections(TUTORIAL, rays)
        self.assertEqual(counts.shape, (2, 3))
        every = self.np.list_intersections(TUTORIAL, rays)
        self.assertEqual(every["ray_splits"].shape, (7,))
        self.assertEqual(int(every["ray_splits"][-1]), int(counts.sum()))
        self.assertEqual(every["primitive_normals"].shape, (int(counts.sum()), 3))
        with self.assertRaises(ValueError):
            self.np.cast_rays(TUTORIAL, np.zeros((4, 5)))

    def test_points_numpy(self) -> None:
        np = numpy
        pts = np.array([[[0, 0, 0], [0, 0, 10]]], dtype=np.float64)
        d = self.np.compute_distance(TUTORIAL, pts)
        self.assertEqual(d.shape, (1, 2))
        occ = self.np.compute_occupancy(TUTORIAL, pts)
        np.testing.assert_array_equal(occ, [[0.0, 1.0]])
        cp = self.np.compute_closest_points(TRIANGLE, pts.astype(np.float32))
        self.assertEqual(cp["points"].shape, (1, 2, 3))
        self.assertEqual(cp["primitive_ids"].dtype, np.uint32)


if __name__ == "__main__":
    unittest.main()
