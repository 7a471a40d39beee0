"""colmap_irav4.rotation_averaging on synthetic view graphs with known
rotations (every method), and its input checks."""

import os
import unittest

import numpy as np

import colmap_irav4

from common import (EXAMPLE_DB, TempDirTestCase, require_binary,
                    run_command)


def random_rotation(rng):
    q = rng.normal(size=4)
    q /= np.linalg.norm(q)
    w, x, y, z = q
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def axis_angle(axis, angle):
    axis = axis / np.linalg.norm(axis)
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]],
                  [-axis[1], axis[0], 0]])
    return np.eye(3) + np.sin(angle) * k + (1 - np.cos(angle)) * k @ k


def angle_deg(a, b):
    cos = (np.trace(a @ b.T) - 1) / 2
    return np.degrees(np.arccos(np.clip(cos, -1, 1)))


def synthetic_graph(seed, num_images=40, degree=8, noise_deg=1.0,
                    outlier_rate=0.0):
    """Rotations R_i (cam_from_world), pairs (i, j) with
    R_ij = R_j R_i^T perturbed by noise_deg, a share of them replaced by
    random rotations (outliers)."""
    rng = np.random.default_rng(seed)
    truth = np.array([random_rotation(rng) for _ in range(num_images)])
    pairs = set()
    for i in range(num_images):  # a ring keeps the graph connected
        pairs.add((i, (i + 1) % num_images))
    while len(pairs) < num_images * degree // 2:
        i, j = rng.choice(num_images, 2, replace=False)
        if (j, i) not in pairs:
            pairs.add((int(i), int(j)))
    pairs = np.array(sorted(pairs))
    relative = []
    for i, j in pairs:
        noise = axis_angle(rng.normal(size=3),
                           np.radians(rng.normal(scale=noise_deg)))
        relative.append(noise @ truth[j] @ truth[i].T)
    relative = np.array(relative)
    num_outliers = int(outlier_rate * len(pairs))
    for k in rng.choice(len(pairs), num_outliers, replace=False):
        relative[k] = random_rotation(rng)
    return truth, pairs, relative


def errors_after_gauge(estimate, truth):
    """Errors (deg) after the global rotation G (R_i -> R_i G) that best
    maps the estimate onto the truth (chordal mean of R_i^T R_i^est)."""
    mask = ~np.isnan(estimate).any(axis=(1, 2))
    m = sum(truth[i].T @ estimate[i] for i in np.flatnonzero(mask))
    u, _, vt = np.linalg.svd(m)
    g = u @ np.diag([1, 1, np.linalg.det(u @ vt)]) @ vt
    return np.array([angle_deg(estimate[i], truth[i] @ g)
                     for i in np.flatnonzero(mask)])


class RotationAveragingTest(unittest.TestCase):
    def test_every_method_recovers_the_truth(self):
        methods = colmap_irav4.rotation_averaging_methods
        self.assertIn("irav4", methods)
        for seed in (1, 2):
            truth, pairs, relative = synthetic_graph(seed)
            for method in methods:
                with self.subTest(seed=seed, method=method):
                    rotations, summary = colmap_irav4.rotation_averaging(
                        len(truth), pairs, relative, method=method)
                    self.assertEqual(rotations.shape, (len(truth), 3, 3))
                    self.assertEqual(summary["num_cameras_estimated"],
                                     len(truth))
                    self.assertEqual(summary["method"], method)
                    errors = errors_after_gauge(rotations, truth)
                    self.assertEqual(len(errors), len(truth))
                    # 1 deg noise per pair: averaging over ~8 pairs per
                    # image gives well under 1 deg, a spanning tree chains
                    # the noise of up to a few pairs.
                    bound = 3.0 if method == "spanning_tree" else 1.0
                    self.assertLess(np.median(errors), bound)

    def test_robust_methods_reject_outliers(self):
        for seed in (3, 4):
            truth, pairs, relative = synthetic_graph(seed, outlier_rate=0.2)
            for method in ("irav4", "ira", "l1_irls"):
                with self.subTest(seed=seed, method=method):
                    rotations, summary = colmap_irav4.rotation_averaging(
                        len(truth), pairs, relative, method=method)
                    errors = errors_after_gauge(rotations, truth)
                    self.assertGreaterEqual(len(errors), len(truth) - 2)
                    self.assertLess(np.median(errors), 1.5)
                    if method == "irav4":
                        self.assertGreater(summary["reference_size"], 0)

    def test_images_outside_the_largest_component_are_nan(self):
        truth, pairs, relative = synthetic_graph(5, num_images=20)
        # Two more images joined only to each other.
        pairs = np.vstack([pairs, [[20, 21]]])
        relative = np.concatenate([relative, [np.eye(3)]])
        weights = np.full(len(pairs), 100.0)
        rotations, summary = colmap_irav4.rotation_averaging(
            22, pairs, relative, weights=weights)
        self.assertTrue(np.isnan(rotations[20:]).all())
        self.assertFalse(np.isnan(rotations[:20]).any())
        self.assertEqual(summary["num_components"], 2)
        self.assertEqual(summary["num_cameras"], 20)
        self.assertLess(np.median(errors_after_gauge(rotations[:20], truth)),
                        1.0)

    def test_options_reach_the_method(self):
        truth, pairs, relative = synthetic_graph(6, outlier_rate=0.2)
        _, summary = colmap_irav4.rotation_averaging(
            len(truth), pairs, relative, method="irav4",
            options={"RotationAveraging": {"final_refinement": "none"}})
        self.assertNotIn("refinement", " ".join(summary["stage_seconds"]))
        _, summary = colmap_irav4.rotation_averaging(
            len(truth), pairs, relative, method="irav4")
        self.assertIn("refinement", " ".join(summary["stage_seconds"]))

    def test_bad_input_names_the_argument(self):
        truth, pairs, relative = synthetic_graph(7, num_images=10)
        n = len(truth)
        bad_rotation = relative.copy()
        bad_rotation[3] *= 2
        nan_rotation = relative.copy()
        nan_rotation[4, 0, 0] = np.nan
        duplicate = pairs.copy()
        duplicate[1] = duplicate[0][::-1]
        cases = [
            (dict(pairs=pairs[:, :1]), "pairs"),
            (dict(pairs=pairs.astype(float)), "pairs"),
            (dict(pairs=np.where(pairs == 0, n, pairs)), r"pairs\[\d+\]"),
            (dict(pairs=duplicate), r"pairs\[1\]"),
            (dict(relative_rotations=relative[:-1]), "relative_rotations"),
            (dict(relative_rotations=bad_rotation),
             r"relative_rotations\[3\]"),
            (dict(relative_rotations=nan_rotation),
             r"relative_rotations\[4\]"),
            (dict(weights=np.zeros(len(pairs))), r"weights\[0\]"),
            (dict(weights=np.ones(2)), "weights"),
            (dict(method="magic"), "method"),
            (dict(options={"RotationAveraging": {"no_such": 1}}),
             "RotationAveraging.no_such"),
            (dict(options={"RotationAveraging": {"theta_deg": "x"}}),
             "RotationAveraging.theta_deg"),
            (dict(num_images=0), "num_images"),
        ]
        for change, name in cases:
            arguments = dict(num_images=n, pairs=pairs,
                             relative_rotations=relative)
            arguments.update(change)
            with self.subTest(change=list(change)):
                with self.assertRaisesRegex(ValueError, name):
                    colmap_irav4.rotation_averaging(**arguments)


def quaternion_to_rotation(w, x, y, z):
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


class ViewGraphTest(TempDirTestCase):
    def test_same_rotations_as_the_command_on_the_example(self):
        """view_graph + rotation_averaging give the rotation_averager
        command's rotations on the bundled example, for every method."""
        require_binary(self)
        graph = colmap_irav4.view_graph(EXAMPLE_DB)
        names = graph["image_names"]
        self.assertEqual(len(names), 11)
        self.assertEqual(graph["pairs"].shape, (55, 2))
        self.assertTrue((graph["weights"] >= 15).all())
        for method in colmap_irav4.rotation_averaging_methods:
            with self.subTest(method=method):
                path = os.path.join(self.tmp, method + ".txt")
                run_command("rotation_averager", "--database_path",
                            EXAMPLE_DB, "--method", method, "--output_path",
                            path)
                expected = {}
                with open(path) as f:
                    for line in f:
                        name, *q = line.split()
                        expected[name] = quaternion_to_rotation(
                            *map(float, q))
                rotations, _ = colmap_irav4.rotation_averaging(
                    len(names), graph["pairs"], graph["relative_rotations"],
                    weights=graph["weights"], method=method)
                self.assertEqual(sorted(expected), sorted(names))
                for k, name in enumerate(names):
                    # The file holds 17 digits of a quaternion.
                    np.testing.assert_allclose(rotations[k], expected[name],
                                               atol=1e-12)

    def test_bad_options_name_the_option(self):
        with self.assertRaisesRegex(ValueError, "ViewGraph.no_such"):
            colmap_irav4.view_graph(EXAMPLE_DB,
                                    options={"ViewGraph": {"no_such": 1}})
        with self.assertRaisesRegex(ValueError, "missing.db"):
            colmap_irav4.view_graph(os.path.join(self.tmp, "missing.db"))


if __name__ == "__main__":
    unittest.main()
